//! Messages that never arrived: the gaps in each publisher's sequence numbers,
//! counted on Zenoh's thread for every sample a subscriber receives.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use zenoh::bytes::ZBytes;
use zenoh::sample::Sample;

use crate::rmw::{Attachment, AttachmentError, Gid};

/// A publisher, as its samples identify it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Source {
    /// Zenoh `SourceInfo` (ours on a plain key, zenoh-ext's advanced publishers).
    Zenoh(zenoh::session::EntityGlobalId),
    /// The GID in an rmw_zenoh attachment (a node's, rmw_zenoh_cpp's).
    Rmw(Gid),
}

/// How many publishers [`LastSeen`] looks up by comparing, before hashing.
const FEW: usize = 8;

/// The highest sequence number seen from each publisher. Most topics have a
/// few publishers: they are found by comparing, without hashing; the rest by
/// a seeded fast hash, as their keys come from the network.
#[derive(Default)]
struct LastSeen {
    few: Vec<(Source, u64)>,
    many: HashMap<Source, u64, foldhash::fast::RandomState>,
}

impl LastSeen {
    /// Record message `sn` of `source`: how many of its messages before it
    /// never arrived.
    #[inline]
    fn record(&mut self, source: Source, sn: u64) -> u64 {
        let last = self.of(source, sn);
        match sn.checked_sub(*last) {
            Some(ahead) => {
                *last = sn;
                ahead.saturating_sub(1)
            }
            // Late, duplicated or reordered: keep the highest.
            None => 0,
        }
    }

    /// The highest sequence number seen from `source`; `sn` if it is new.
    #[inline]
    fn of(&mut self, source: Source, sn: u64) -> &mut u64 {
        match self.few.iter().position(|(s, _)| *s == source) {
            Some(i) => &mut self.few[i].1,
            None if self.few.len() < FEW => {
                let i = self.few.len();
                self.few.push((source, sn));
                &mut self.few[i].1
            }
            None => self.many.entry(source).or_insert(sn),
        }
    }
}

/// The publishers seen and how many messages the gaps in their sequence
/// numbers say never arrived.
pub(crate) struct Gaps {
    /// The first publisher heard from, followed without a lock (most topics
    /// have one publisher): one more than its highest sequence number, 0
    /// before its first message.
    first: OnceLock<Source>,
    first_next: AtomicU64,
    /// The others.
    last_seen: Mutex<LastSeen>,
    pub(crate) missed: Arc<AtomicU64>,
    key_expr: Arc<str>,
}

impl Gaps {
    pub(crate) fn new(key_expr: &str) -> Self {
        Self {
            first: OnceLock::new(),
            first_next: AtomicU64::new(0),
            last_seen: Mutex::new(LastSeen::default()),
            missed: Arc::new(AtomicU64::new(0)),
            key_expr: key_expr.into(),
        }
    }

    /// Record message `sn` of `source`: how many of its messages before it
    /// never arrived.
    #[inline]
    fn record(&self, source: Source, sn: u64) -> u64 {
        if *self.first.get_or_init(|| source) != source {
            return self
                .last_seen
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .record(source, sn);
        }
        let next = sn.saturating_add(1);
        match self.first_next.fetch_max(next, Ordering::Relaxed) {
            0 => 0,
            previous => next.saturating_sub(previous).saturating_sub(1),
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
        } else if let Some(Ok(attachment)) = sample.attachment().map(parse_attachment) {
            let Ok(sn) = u64::try_from(attachment.sequence_number) else {
                return;
            };
            (Source::Rmw(attachment.gid), sn)
        } else {
            return;
        };
        let gap = self.record(source, sn);
        if gap > 0 && self.missed.fetch_add(gap, Ordering::Relaxed) == 0 {
            tracing::warn!(
                key_expr = %self.key_expr,
                count = gap,
                "messages never arrived (a gap in the publisher's sequence numbers); RosSubscriber::missed() counts them"
            );
        }
    }
}

/// An attachment read in place when it is one slice, as Zenoh delivers it.
#[inline]
fn parse_attachment(attachment: &ZBytes) -> Result<Attachment, AttachmentError> {
    let mut slices = attachment.slices();
    match (slices.next(), slices.next()) {
        (Some(only), None) => Attachment::parse(only),
        _ => Attachment::parse(&attachment.to_bytes()),
    }
}

#[cfg(test)]
mod tests {
    use super::{Gaps, Source, FEW};
    use crate::rmw::Gid;

    fn source(i: usize) -> Source {
        let mut gid = [0u8; 16];
        gid[15] = i as u8;
        Source::Rmw(Gid(gid))
    }

    /// The first publisher (followed without a lock), the few compared ones
    /// and those beyond are followed alike: each counts its own gaps,
    /// whatever the others send between its messages.
    #[test]
    fn each_publisher_counts_its_own_gaps_first_few_or_many() {
        let publishers = 1 + FEW + 4;
        let seen = Gaps::new("test");
        let mut missed = vec![0u64; publishers];
        // Publisher i skips its message 3 when i is even, and sends 2 late.
        for sn in 1..=6u64 {
            for (i, m) in missed.iter_mut().enumerate() {
                if i % 2 == 0 && sn == 3 {
                    continue;
                }
                *m += seen.record(source(i), sn);
                if sn == 5 {
                    *m += seen.record(source(i), 2);
                }
            }
        }
        let expected: Vec<u64> = (0..publishers).map(|i| u64::from(i % 2 == 0)).collect();
        assert_eq!(missed, expected);
        assert_eq!(seen.first.get(), Some(&source(0)));
        let others = seen.last_seen.lock().unwrap();
        assert_eq!(others.few.len(), FEW);
        assert_eq!(others.many.len(), publishers - 1 - FEW);
    }

    /// A publisher is followed from the first message received of it, whatever
    /// its number: one joined late has no gap before it.
    #[test]
    fn a_publisher_is_followed_from_its_first_message_received() {
        let publishers = 1 + FEW + 4;
        let seen = Gaps::new("test");
        for i in 0..publishers {
            assert_eq!(seen.record(source(i), 500), 0, "publisher {i}");
            assert_eq!(seen.record(source(i), 503), 2, "publisher {i}");
        }
    }
}
