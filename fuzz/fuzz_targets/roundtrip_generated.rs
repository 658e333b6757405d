//! An arbitrary message: exact size, padding written over garbage, short buffers
//! refused, decode(encode(x)) == x, in both byte orders.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shm_cdr_tests::fuzzing::roundtrip_generated(data));
