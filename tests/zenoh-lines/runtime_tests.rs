//! shm-runtime's shared-memory, graph, service, action and durability tests,
//! built as one test binary of an outside project on one Zenoh line
//! (tests/zenoh-lines/<line>/Cargo.toml): one link against that line's Zenoh
//! instead of one per file. Each file keeps its own `mod common;`, found beside
//! it in shm-runtime/tests/.

#[path = "../../shm-runtime/tests/zenoh_line.rs"]
mod zenoh_line;

#[path = "../../shm-runtime/tests/end_to_end.rs"]
mod end_to_end;

#[path = "../../shm-runtime/tests/loans.rs"]
mod loans;

#[path = "../../shm-runtime/tests/unprobed_receivers.rs"]
mod unprobed_receivers;

#[path = "../../shm-runtime/tests/shared_views.rs"]
mod shared_views;

#[path = "../../shm-runtime/tests/two_pools.rs"]
mod two_pools;

#[path = "../../shm-runtime/tests/services.rs"]
mod services;

#[path = "../../shm-runtime/tests/actions.rs"]
mod actions;

#[path = "../../shm-runtime/tests/distros.rs"]
mod distros;

#[path = "../../shm-runtime/tests/durability.rs"]
mod durability;
