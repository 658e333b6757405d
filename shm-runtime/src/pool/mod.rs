//! The shared-memory pool: one Zenoh POSIX provider shared by the publishers of a
//! context, with bounded waiting and counted heap fallbacks.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use zenoh::shm::{
    AllocAlignment, Defragment, GarbageCollect, PosixShmProviderBackend, ShmProvider,
    ShmProviderBuilder, ZShmMut,
};
use zenoh::Wait;

use crate::config::{ConfigError, ShmConfig};

mod backend;

pub use backend::CdrBackend;

/// Allocations from this size up reclaim dropped chunks first (see
/// [`ShmContext::alloc_bounded`]). Below it, writing into cold memory costs little,
/// while the collection scans every chunk still borrowed (measured: 0.7 µs with
/// 1 000 held, 6.7 µs with 10 000), so small messages leave reclamation to the
/// allocation that finds the pool full, which amortizes one scan over a pool's
/// worth of messages.
const EAGER_RECLAIM_MIN_LEN: usize = 64 * 1024;

/// A shared-memory pool and the settings publishers use with it. Cheap to clone;
/// clones share the pool and the counters.
#[derive(Clone)]
pub struct ShmContext {
    inner: Arc<Inner>,
}

struct Inner {
    provider: ShmProvider<CdrBackend>,
    config: ShmConfig,
    stats: Counters,
}

#[derive(Default)]
struct Counters {
    shm: AtomicU64,
    heap: AtomicU64,
    fallbacks: AtomicU64,
    too_large: AtomicU64,
}

/// How many messages went where (see [`ShmContext::stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShmStats {
    /// Messages encoded into shared memory (including zero-copy splices).
    pub shm: u64,
    /// Messages below the threshold, encoded on the heap by design.
    pub heap: u64,
    /// Messages above the threshold that found the pool full after the bounded
    /// wait and were published from the heap instead.
    pub fallbacks: u64,
    /// Messages larger than the whole pool, which can never fit and were
    /// published from the heap.
    pub too_large: u64,
}

impl std::fmt::Debug for ShmContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShmContext")
            .field("config", &self.inner.config)
            .field("stats", &self.stats())
            .finish()
    }
}

impl ShmContext {
    /// Create a pool of `config.pool_size` bytes. Settings Zenoh would refuse
    /// are refused first ([`ShmConfig::validate`]); a pool the system cannot
    /// provide (e.g. larger than `/dev/shm`) is an error that says so.
    pub fn new(config: ShmConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let provider = PosixShmProviderBackend::builder(config.pool_size)
            .wait()
            .map(|posix| ShmProviderBuilder::backend(CdrBackend::new(posix)).wait())
            .map_err(|e| ConfigError {
                setting: "ShmConfig::pool_size",
                value: config.pool_size.to_string(),
                reason: format!(
                    "Zenoh could not create a shared-memory pool of that size ({e}); check the room in /dev/shm (`df -h /dev/shm`; in Docker, `--shm-size`)"
                ),
            })?;
        if config.threshold > config.pool_size {
            tracing::warn!(
                threshold = config.threshold,
                pool_size = config.pool_size,
                "SHM threshold above the pool size: no message will ever use shared memory"
            );
        }
        if config.prefault {
            prefault(&provider, config.pool_size);
        }
        Ok(Self {
            inner: Arc::new(Inner {
                provider,
                config,
                stats: Counters::default(),
            }),
        })
    }

    /// A pool configured from `ZENOH_SHM_ALLOC_SIZE` /
    /// `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD`, or `None` if neither is set.
    pub fn from_env() -> Result<Option<Self>, ConfigError> {
        match ShmConfig::from_env()? {
            Some(config) => Ok(Some(Self::new(config)?)),
            None => Ok(None),
        }
    }

    /// The settings of this pool.
    pub fn config(&self) -> ShmConfig {
        self.inner.config
    }

    /// The underlying Zenoh provider, to allocate buffers for user-managed fields
    /// (see [`ShmBytes`](crate::ShmBytes)). Its chunks requested with an alignment
    /// of at most 4 bytes (the default) start at 4 mod 8, where a CDR message's body
    /// is 8-aligned; see [`CdrBackend`].
    pub fn provider(&self) -> &ShmProvider<CdrBackend> {
        &self.inner.provider
    }

    /// Allocate exactly `len` bytes of shared memory for the application to fill
    /// (e.g. the point data of a cloud), waiting at most the configured timeout for
    /// space. `None` if the pool stays full. Like every chunk this pool hands out
    /// without an explicit alignment, it starts at 4 mod 8 (see [`CdrBackend`]).
    pub fn alloc(&self, len: usize) -> Option<ZShmMut> {
        self.alloc_message(len, self.inner.config.alloc_timeout)
    }

    /// Allocate exactly `len` bytes for a whole CDR message (header included):
    /// the chunk starts at 4 mod 8, so the message body is 8-aligned.
    pub(crate) fn alloc_message(&self, len: usize, timeout: Duration) -> Option<ZShmMut> {
        self.alloc_bounded(len, AllocAlignment::ALIGN_1_BYTE, timeout)
    }

    /// Counters since the pool was created.
    pub fn stats(&self) -> ShmStats {
        let c = &self.inner.stats;
        ShmStats {
            shm: c.shm.load(Ordering::Relaxed),
            heap: c.heap.load(Ordering::Relaxed),
            fallbacks: c.fallbacks.load(Ordering::Relaxed),
            too_large: c.too_large.load(Ordering::Relaxed),
        }
    }

    /// Try to allocate `len` bytes: reclaim buffers the readers have dropped
    /// (garbage collection), then defragment; if the pool is still full, retry
    /// with short sleeps until `timeout` has passed. Never blocks longer.
    fn alloc_bounded(
        &self,
        len: usize,
        align: AllocAlignment,
        timeout: Duration,
    ) -> Option<ZShmMut> {
        if len == 0 || len > self.inner.config.pool_size {
            return None;
        }
        let deadline = Instant::now() + timeout;
        let mut pause = Duration::from_micros(20);
        // Reclaim what readers have dropped *before* allocating a large buffer, not
        // only when an allocation fails (Zenoh's policy): the allocator then reuses
        // the chunk just released, still in cache, instead of walking on through
        // cold pool pages. Filling 1 MiB takes ~22 µs instead of ~80 µs that way
        // (see the latency bench). It is sound because the safe collection frees
        // only chunks whose reference count is zero, and a chunk in transit is
        // never at zero: Zenoh takes a reference for the receiver when it
        // serializes the message, inside `put`, before our own is dropped.
        if len >= EAGER_RECLAIM_MIN_LEN {
            self.inner.provider.garbage_collect();
        }
        loop {
            match self
                .inner
                .provider
                .alloc((len, align))
                .with_policy::<Defragment<GarbageCollect>>()
                .wait()
            {
                Ok(buffer) => return Some(buffer),
                Err(error) => {
                    let now = Instant::now();
                    if now >= deadline {
                        tracing::debug!(len, ?error, "shared-memory pool full after waiting");
                        return None;
                    }
                    std::thread::sleep(pause.min(deadline - now));
                    pause = (pause * 2).min(Duration::from_millis(1));
                }
            }
        }
    }

    /// Reclaim buffers whose readers are gone: chunks still counted as borrowed
    /// whose Zenoh watchdog has expired because no process confirmed them for a
    /// watchdog period (100 ms in Zenoh 1.10). This is how a publisher gets back
    /// the shared memory that a crashed subscriber process was holding; the
    /// automatic collection never does it, because a dead reader's reference is
    /// never released. Returns the size of the largest chunk reclaimed (0 if none).
    ///
    /// # Safety
    /// No live reader of this pool, in any process, may be holding a sample whose
    /// watchdog expired: a reader stalled for longer than the watchdog period while
    /// borrowing a sample would have the chunk reused, and its contents
    /// overwritten, under it. Call it when a subscriber process is known to have
    /// died (e.g. after its supervisor reports the exit), not on a timer.
    pub unsafe fn reclaim_abandoned(&self) -> usize {
        // SAFETY: forwarded to the caller (see above); this is exactly Zenoh's
        // contract for `garbage_collect_unsafe`, which frees refcounted chunks
        // only when their watchdog is invalidated.
        let largest = unsafe { self.inner.provider.garbage_collect_unsafe() };
        self.inner.provider.defragment();
        tracing::info!(largest, "reclaimed shared memory abandoned by dead readers");
        largest
    }

    pub(crate) fn count_shm(&self) {
        self.inner.stats.shm.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn count_heap(&self) {
        self.inner.stats.heap.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn count_fallback(&self, size: usize) {
        let n = self.inner.stats.fallbacks.fetch_add(1, Ordering::Relaxed) + 1;
        // The 1st, 2nd, 4th, 8th… time: visible, without a line per message.
        if n.is_power_of_two() {
            tracing::warn!(
                size,
                fallbacks = n,
                pool_size = self.inner.config.pool_size,
                "shared-memory pool exhausted: message published from the heap (ShmContext::stats() counts them)"
            );
        }
    }

    pub(crate) fn count_too_large(&self, size: usize) {
        if self.inner.stats.too_large.fetch_add(1, Ordering::Relaxed) == 0 {
            tracing::warn!(
                size,
                pool_size = self.inner.config.pool_size,
                "message larger than the whole shared-memory pool: it can never fit, so it is published from the heap; enlarge the pool (ShmConfig::pool_size / ZENOH_SHM_ALLOC_SIZE) to send it through shared memory"
            );
        }
    }
}

/// Touch every page of the pool once, so that publishing never pays first-touch
/// page faults (about 0.25 µs per 4 KiB page, i.e. ~60 µs for each fresh MiB the
/// allocator moves on to). Best effort: whatever cannot be allocated is skipped.
fn prefault(provider: &ShmProvider<CdrBackend>, pool_size: usize) {
    const CHUNK: usize = 1 << 20;
    let mut held = Vec::new();
    let mut left = pool_size;
    while left > 0 {
        let len = left.min(CHUNK);
        match provider.alloc(len).wait() {
            Ok(mut buffer) => {
                buffer.fill(0);
                held.push(buffer);
                left -= len;
            }
            Err(_) => break,
        }
    }
    drop(held);
    provider.garbage_collect();
    provider.defragment();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_chunks_put_the_body_on_8_and_free_back_to_a_full_pool() {
        let pool_size = 64 * 1024;
        let pool =
            ShmContext::new(ShmConfig::enabled().pool_size(pool_size).prefault(false)).unwrap();
        // The largest message chunk a fresh pool gives (talc keeps some bytes).
        let largest = |pool: &ShmContext| {
            let (mut lo, mut hi) = (1, pool_size);
            while lo < hi {
                let mid = (lo + hi).div_ceil(2);
                match pool.alloc_message(mid, Duration::ZERO) {
                    Some(_) => lo = mid,
                    None => hi = mid - 1,
                }
                pool.provider().garbage_collect();
            }
            lo
        };
        let fresh = largest(&pool);
        assert!(fresh > pool_size * 9 / 10, "{fresh}");
        for round in 0..3 {
            // Odd sizes, shifted and not, until the pool is full.
            let mut held = Vec::new();
            for len in (1usize..).map(|i| 1 + (i * 37) % 3000) {
                // An explicit alignment is honoured, unshifted: every inner chunk
                // is 8-aligned, so one at 4 mod 8 is always a shifted one (an
                // ALIGN_4 chunk there would be freed as shifted and corrupt
                // the allocator).
                let align = [
                    AllocAlignment::ALIGN_1_BYTE,
                    AllocAlignment::ALIGN_4_BYTES,
                    AllocAlignment::ALIGN_1_BYTE,
                    AllocAlignment::ALIGN_8_BYTES,
                ][held.len() % 4];
                let shifted = align == AllocAlignment::ALIGN_1_BYTE;
                let len = if shifted {
                    len
                } else {
                    len.next_multiple_of(align.get_alignment_value().get())
                };
                let chunk = pool.alloc_bounded(len, align, Duration::ZERO);
                let Some(mut chunk) = chunk else { break };
                assert_eq!(chunk.len(), len);
                let addr = chunk.as_ptr() as usize;
                assert_eq!(addr % 8, if shifted { 4 } else { 0 }, "round {round}");
                chunk.fill(round as u8);
                held.push(chunk);
            }
            assert!(held.len() > 20, "round {round}: {} chunks", held.len());
            drop(held);
            pool.provider().garbage_collect();
            pool.provider().defragment();
            // Everything came back.
            assert_eq!(largest(&pool), fresh, "round {round}");
        }
    }
}
