//! Runnable examples: `cargo run -p shm-cdr-examples --example <name>`.
