//! Arbitrary bytes into several message types: no panic, no hang, no allocation
//! beyond what the input justifies; whatever decodes re-encodes consistently.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shm_cdr_tests::fuzzing::decode(data));
