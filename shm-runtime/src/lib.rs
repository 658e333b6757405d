//! Zenoh shared-memory glue for [`shm_cdr`] messages.
//!
//! Not built yet: this crate will size a Zenoh `ZShmMut` with
//! [`shm_cdr::encoded_size`], encode straight into it with [`shm_cdr::encode_into`]
//! and publish it inside the caller's own `zenoh::Session`. Until then it only
//! re-exports the wire format so downstream code can depend on the final crate name.
#![warn(missing_docs)]

pub use shm_cdr;
