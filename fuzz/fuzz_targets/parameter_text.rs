//! See `shm_cdr_tests::fuzzing::parameter_text`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shm_cdr_tests::fuzzing::parameter_text(data));
