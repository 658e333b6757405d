//! See `shm_cdr_tests::fuzzing::liveliness_tokens`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shm_cdr_tests::fuzzing::liveliness_tokens(data));
