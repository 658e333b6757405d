//! Messages that never arrived: the gaps in each publisher's sequence numbers,
//! counted on Zenoh's thread for every sample a subscriber receives.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use zenoh::sample::Sample;

use crate::rmw::{Attachment, Gid};

/// A publisher, as its samples identify it.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Source {
    /// Zenoh `SourceInfo` (ours on a plain key, zenoh-ext's advanced publishers).
    Zenoh(zenoh::session::EntityGlobalId),
    /// The GID in an rmw_zenoh attachment (a node's, rmw_zenoh_cpp's).
    Rmw(Gid),
}

/// The highest sequence number seen from each publisher, and how many
/// messages the gaps between them say never arrived.
pub(crate) struct Gaps {
    /// A seeded fast hash: every sample looks its publisher up, and the keys
    /// come from the network.
    last_seen: Mutex<HashMap<Source, u64, foldhash::fast::RandomState>>,
    pub(crate) missed: Arc<AtomicU64>,
    key_expr: Arc<str>,
}

impl Gaps {
    pub(crate) fn new(key_expr: &str) -> Self {
        Self {
            last_seen: Mutex::new(HashMap::default()),
            missed: Arc::new(AtomicU64::new(0)),
            key_expr: key_expr.into(),
        }
    }

    /// Count the messages a gap in the sample's publisher's sequence numbers
    /// says never arrived (Zenoh `SourceInfo`, else the rmw_zenoh attachment);
    /// samples with neither are not numbered.
    #[inline]
    pub(crate) fn check(&self, sample: &Sample) {
        let (source, sn) = if let Some(info) = sample.source_info() {
            (
                Source::Zenoh(*info.source_id()),
                u64::from(info.source_sn()),
            )
        } else if let Some(Ok(attachment)) = sample
            .attachment()
            .map(|a| Attachment::parse(&a.to_bytes()))
        {
            let Ok(sn) = u64::try_from(attachment.sequence_number) else {
                return;
            };
            (Source::Rmw(attachment.gid), sn)
        } else {
            return;
        };
        let gap = {
            let mut last_seen = self.last_seen.lock().unwrap_or_else(|e| e.into_inner());
            let last = last_seen.entry(source).or_insert(sn);
            match sn.checked_sub(*last) {
                Some(ahead) => {
                    *last = sn;
                    ahead.saturating_sub(1)
                }
                // Late, duplicated or reordered: keep the highest.
                None => 0,
            }
        };
        if gap > 0 && self.missed.fetch_add(gap, Ordering::Relaxed) == 0 {
            tracing::warn!(
                key_expr = %self.key_expr,
                count = gap,
                "messages never arrived (a gap in the publisher's sequence numbers); RosSubscriber::missed() counts them"
            );
        }
    }
}
