//! A count of changes to some state, so that an answer found from it can be
//! kept until it changes: what lets a publisher skip its receivers'
//! bookkeeping on every message while nothing about them moved.

use std::sync::atomic::{AtomicU64, Ordering};

/// How many times some state has changed. A writer calls [`note`](Self::note)
/// after each change (with the state's lock released or not); a reader takes
/// [`seen`](Self::seen) before it reads the state, and may reuse what it found
/// for as long as `seen` returns the same number. A change made while the
/// reader read is counted after it, so the reader finds it next time.
#[derive(Debug, Default)]
pub(crate) struct Changes(AtomicU64);

impl Changes {
    /// Count a change, after making it.
    pub(crate) fn note(&self) {
        self.0.fetch_add(1, Ordering::Release);
    }

    /// The changes so far, before reading the state.
    pub(crate) fn seen(&self) -> u64 {
        self.0.load(Ordering::Acquire)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_change_moves_the_count() {
        let changes = Changes::default();
        let before = changes.seen();
        assert_eq!(changes.seen(), before);
        changes.note();
        assert_ne!(changes.seen(), before);
    }
}
