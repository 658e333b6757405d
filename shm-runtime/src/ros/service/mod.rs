//! ROS 2 services as rmw_zenoh_cpp carries them.
//!
//! A server is a complete Zenoh queryable on the service's key
//! ([`service_key_expr`](crate::rmw::service_key_expr)) with an `SS` liveliness
//! token; a call is a Zenoh query (target all-complete, no consolidation) whose
//! payload is the CDR request and whose attachment is rmw_zenoh's 33 bytes
//! {sequence number from 1, timestamp, client GID}; the reply carries the CDR
//! response and an attachment with the *request's* sequence number and the
//! *client's* GID. Requests and responses at or above the shared-memory
//! threshold travel in shared memory, encoded straight into an exact-size buffer,
//! like published messages.
//!
//! ```no_run
//! use shm_runtime::shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Response};
//! use shm_runtime::RosNode;
//! use zenoh::Wait;
//!
//! let session = zenoh::open(zenoh::Config::default()).wait()?;
//! let node = RosNode::builder(&session, "demo").wait()?;
//! let _server = node
//!     .declare_service::<Trigger>("/trigger")
//!     .handler(|_request| Trigger_Response { success: true, message: "done".into() })
//!     .wait()?;
//! let client = node.declare_client::<Trigger>("/trigger").wait()?;
//! let response = client.call(&Default::default()).wait()?;
//! assert!(response.success);
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```

mod client;
mod server;

pub(crate) use client::NO_TIMEOUT;
pub use client::{CallBuilder, CallError, ServiceClient, ServiceClientBuilder, ServiceReply};
pub use server::{
    CallbackServiceServer, CallbackServiceServerBuilder, ReplyBuilder, ServiceRequest,
    ServiceServer, ServiceServerBuilder,
};

/// The payload of the error reply a server sends for a request it could not
/// take: `shm-runtime: <why>`, so a client (ours or rmw_zenoh_cpp's log) says
/// what went wrong on the other side.
fn error_reply_text(why: impl std::fmt::Display) -> String {
    format!("shm-runtime: {why}")
}
