//! Side-by-side comparison of shm-cdr with the CDR libraries a Rust user would
//! otherwise pick: `hiroz-cdr` (hiroz / ros-z), `cdr` and `cdr-encoding`
//! (serde-based; RustDDS uses the latter), and eProsima Fast-CDR (the C++
//! library under ROS 2's rmw_fastrtps and rmw_zenoh_cpp) through a C++ shim.
//!
//! Nothing depends on this crate, so users never compile the peers. The
//! benchmark (`cargo bench -p shm-cdr-peer-bench`) first runs [`check`]: a
//! library whose bytes differ from ours for a message is reported and not
//! timed on it, because a benchmark of a wrong encoder proves nothing. Our own
//! bytes are the reference because the `shm-cdr-tests` crate proves them equal
//! to rosbags' and pycdr2's.

pub mod check;
#[cfg(fastcdr)]
pub mod fastcdr;
pub mod messages;
pub mod mirror;
pub mod peers;

pub use check::{check, check_all, Verdict};
pub use messages::{samples, Message, Sample};
