//! See `shm_cdr_tests::fuzzing::type_description`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shm_cdr_tests::fuzzing::type_description(data));
