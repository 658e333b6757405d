//! How many bytes one message may carry outside shared memory.
//!
//! Zenoh's normal unicast transport fragments a large message over several
//! batches. Its lowlatency transport (`transport/unicast/lowlatency: true`)
//! writes every message as one frame and cannot: the receiver refuses a frame
//! larger than its batch size and closes the link, while the sender's put has
//! already returned `Ok` (Zenoh 1.9). Shared-memory data travels as a
//! descriptor of a few dozen bytes, so only the inline part counts. Publishers,
//! service clients and servers declared on such a session refuse a message whose
//! inline part would not fit, with [`Unfragmentable`], instead of losing it.

use std::fmt;

use zenoh::Session;

/// A message whose inline (not shared-memory) bytes do not fit in one frame of a
/// transport that cannot fragment (Zenoh's lowlatency transport). Nothing was
/// sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unfragmentable {
    /// Bytes that would have travelled inline: the whole encoding, or the
    /// metadata around spliced shared-memory fields.
    pub inline: usize,
    /// The most this entity sends inline on this session.
    pub limit: usize,
}

impl fmt::Display for Unfragmentable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} bytes would travel outside shared memory over Zenoh's lowlatency transport, which \
             cannot fragment: at most {} fit in one batch (transport/link/tx/batch_size), and the \
             receiver would drop the link. Give this entity a shared-memory pool with room for the \
             message (or a lower threshold), or turn transport/unicast/lowlatency off",
            self.inline, self.limit
        )
    }
}

impl std::error::Error for Unfragmentable {}

/// Zenoh's framing around one message's payload, bounded from above: the frame
/// length, the network and put headers, the key expression and encoding (counted
/// separately), source info (~30 bytes), a timestamp (~20), QoS, an rmw_zenoh
/// attachment (33 + its length) and the payload's length.
const FRAMING: usize = 256;

/// The inline limit of one entity, on a session that cannot fragment.
#[derive(Debug, Clone, Copy)]
pub(crate) struct InlineLimit {
    limit: usize,
}

impl InlineLimit {
    /// The limit for messages on `key_expr` with an encoding of `encoding_len`
    /// bytes, or `None` if `session` fragments (lowlatency off, Zenoh's default).
    ///
    /// From this session's own batch size: a peer configured with a smaller one
    /// lowers the negotiated size, which this side cannot see.
    pub(crate) fn of(session: &Session, key_expr: &str, encoding_len: usize) -> Option<Self> {
        let config = session.config();
        let lowlatency = config
            .get_typed::<bool>("transport/unicast/lowlatency")
            .unwrap_or(false);
        if !lowlatency {
            return None;
        }
        let batch = config
            .get_typed::<u16>("transport/link/tx/batch_size")
            .unwrap_or(u16::MAX);
        let limit = usize::from(batch).saturating_sub(FRAMING + key_expr.len() + encoding_len);
        tracing::debug!(
            key_expr,
            limit,
            "lowlatency transport: messages are refused above this many inline bytes"
        );
        Some(Self { limit })
    }

    /// `Ok` if `inline` bytes fit in one frame.
    #[inline]
    pub(crate) fn check(self, inline: usize) -> Result<(), Unfragmentable> {
        if inline <= self.limit {
            Ok(())
        } else {
            Err(Unfragmentable {
                inline,
                limit: self.limit,
            })
        }
    }
}

/// [`InlineLimit::check`] where there may be no limit.
#[inline]
pub(crate) fn check(limit: Option<InlineLimit>, inline: usize) -> Result<(), Unfragmentable> {
    limit.map_or(Ok(()), |limit| limit.check(inline))
}
