//! What Zenoh cannot carry, refused when an entity is declared rather than
//! met as a panic inside Zenoh.

use std::fmt;
use std::time::Duration;

/// The longest timeout Zenoh carries (`u64::MAX` ms): what "no timeout" means,
/// as rmw_zenoh_cpp uses for an action's `get_result`.
pub(crate) const NO_TIMEOUT: Duration = Duration::from_millis(u64::MAX);

/// The longest key expression (or liveliness token) Zenoh can carry: its wire
/// format gives a key expression a 16-bit length, and Zenoh 1.9 panics,
/// aborting the process, on a longer one.
pub const MAX_KEY_EXPR_LEN: usize = u16::MAX as usize;

/// A key expression or liveliness token longer than [`MAX_KEY_EXPR_LEN`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyExprTooLong {
    /// What it is: `key expression`, `liveliness token`.
    pub what: &'static str,
    /// Its first characters.
    pub start: String,
    /// Its length in bytes.
    pub len: usize,
}

impl fmt::Display for KeyExprTooLong {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {:?}… is {} bytes long; Zenoh carries at most {MAX_KEY_EXPR_LEN} (a 16-bit length): shorten the names in it (topic, namespace, node, type)",
            self.what, self.start, self.len
        )
    }
}

impl std::error::Error for KeyExprTooLong {}

/// `Ok` if Zenoh can carry `key`.
pub(crate) fn check_key_expr(what: &'static str, key: &str) -> Result<(), KeyExprTooLong> {
    if key.len() <= MAX_KEY_EXPR_LEN {
        return Ok(());
    }
    let start: String = key.chars().take(60).collect();
    Err(KeyExprTooLong {
        what,
        start,
        len: key.len(),
    })
}
