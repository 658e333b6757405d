//! The shared-memory pool: one Zenoh POSIX provider shared by the publishers of a
//! context, with bounded waiting and counted heap fallbacks.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use zenoh::shm::{
    AllocAlignment, Defragment, GarbageCollect, PosixShmProviderBackend, ShmProvider,
    ShmProviderBuilder, ZShmMut,
};
use zenoh::Wait;

use crate::transport::config::{ConfigError, PoolSize, ShmConfig};
use crate::transport::encoded::PayloadKind;
use crate::transport::memlock::{Bytes, MemlockBudget, RAISE_THE_LIMIT, ZENOH_METADATA_SEGMENT};
use crate::transport::reach_table::ReachTable;

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
///
/// The pool is sized to the process's memory-lock limit unless a size is
/// given exactly (see [`PoolSize`]); where the limit leaves no room for one,
/// the context has no pool ([`ShmContext::pool_size`] is `None`) and its
/// publishers send from the heap, counted in [`ShmStats::unavailable`].
///
/// ```no_run
/// use shm_runtime::{ShmConfig, ShmContext};
///
/// let shm = ShmContext::new(ShmConfig::enabled())?;
/// match shm.pool_size() {
///     Some(bytes) => println!("pool of {bytes} bytes ({})", shm.memlock()),
///     None => println!("no pool: {}", shm.memlock()),
/// }
/// # Ok::<(), shm_runtime::ConfigError>(())
/// ```
#[derive(Clone)]
pub struct ShmContext {
    inner: Arc<Inner>,
}

struct Inner {
    /// `None` where the memory-lock limit left no room for a pool.
    provider: Option<ShmProvider<CdrBackend>>,
    /// The pool's size in bytes (0 without one).
    size: usize,
    config: ShmConfig,
    memlock: MemlockBudget,
    stats: Counters,
    /// The sessions checked for whether they map this pool.
    reach: ReachTable,
}

#[derive(Default)]
struct Counters {
    shm: AtomicU64,
    heap: AtomicU64,
    fallbacks: AtomicU64,
    too_large: AtomicU64,
    unavailable: AtomicU64,
    pending: AtomicU64,
    cannot_map: AtomicU64,
    copied: AtomicU64,
}

/// How many messages went where (see [`ShmContext::stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[non_exhaustive]
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
    /// Messages above the threshold published from the heap because the
    /// memory-lock limit left no room for a pool (see [`PoolSize::AtMost`]).
    pub unavailable: u64,
    /// Messages above the threshold published from the heap while a
    /// subscribing session was being checked for whether it maps the pool
    /// (see [`Reach`](crate::Reach)).
    pub pending: u64,
    /// Messages above the threshold published from the heap because a
    /// subscribing session cannot map the pool (see [`Reach::CannotMap`](crate::Reach::CannotMap)).
    pub cannot_map: u64,
    /// Messages sent through the pool that at least one subscribing session
    /// got as a copy, its link carrying no shared memory (see
    /// [`Reach::Bytes`](crate::Reach::Bytes)); also counted in `shm`.
    pub copied: u64,
}

impl std::fmt::Debug for ShmContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShmContext")
            .field("config", &self.inner.config)
            .field("pool_size", &self.pool_size())
            .field("stats", &self.stats())
            .finish()
    }
}

/// Whether a pool of this process has allocated, which makes Zenoh lock its
/// metadata segment (once per process, for every pool).
static OWN_METADATA_LOCKED: AtomicBool = AtomicBool::new(false);

/// Pools are sized in whole multiples of this.
const FIT_GRANULE: u64 = 64 * 1024;

/// What a sized pool leaves beside the metadata segments for the rest a
/// process locks: a Zenoh session locks 48 KiB of its own when it starts.
const FIT_SLACK: u64 = 256 * 1024;

/// The size of pool `requested` gets under `memlock`: `Ok(None)` for no pool
/// (an [`PoolSize::AtMost`] pool the limit has no room for), an error for an
/// exact size the limit cannot hold.
fn size_pool(
    requested: PoolSize,
    memlock: &MemlockBudget,
    own_metadata_locked: bool,
    shm_free: Option<u64>,
) -> Result<Option<usize>, ConfigError> {
    let own_metadata = if own_metadata_locked {
        0
    } else {
        ZENOH_METADATA_SEGMENT
    };
    // /dev/shm is shared by every process of the host: a default pool takes
    // at most half of the room left there, an exact one must fit.
    let requested = match (requested, shm_free) {
        (PoolSize::AtMost(max), Some(free)) => {
            let room = free.saturating_sub(own_metadata) / 2 / FIT_GRANULE * FIT_GRANULE;
            PoolSize::AtMost(usize::try_from(room).map_or(max, |room| room.min(max)))
        }
        (PoolSize::Exact(bytes), Some(free)) if bytes as u64 + own_metadata > free => {
            return Err(ConfigError {
                setting: "ShmConfig::pool_size",
                value: bytes.to_string(),
                reason: format!(
                    "/dev/shm has {} free, and this pool needs {} there{}: give /dev/shm more room (Docker: `--shm-size`; compose: `shm_size:`) or ask for a smaller pool",
                    Bytes(free),
                    Bytes(bytes as u64),
                    if own_metadata > 0 {
                        format!(" and Zenoh's metadata segment {} more", Bytes(own_metadata))
                    } else {
                        String::new()
                    },
                ),
            });
        }
        (requested, _) => requested,
    };
    // Unlimited (root, CAP_IPC_LOCK, `ulimit -l unlimited`): as asked.
    let available = memlock.available().unwrap_or(u64::MAX);
    // Half of what is left after the two metadata segments and some slack:
    // the other half maps a peer's pool of the same size.
    let fit = available.saturating_sub(own_metadata + ZENOH_METADATA_SEGMENT + FIT_SLACK)
        / 2
        / FIT_GRANULE
        * FIT_GRANULE;
    match requested {
        PoolSize::AtMost(max) => Ok(usize::try_from(fit)
            .ok()
            .map(|fit| fit.min(max))
            .filter(|&size| size >= ShmConfig::MIN_FIT_POOL_SIZE)),
        PoolSize::Exact(bytes) => {
            let need = (bytes as u64).next_multiple_of(4096) + own_metadata;
            if need > available {
                let instead = if fit >= ShmConfig::MIN_FIT_POOL_SIZE as u64 {
                    format!(
                        "ask for at most {} (ShmConfig::pool_size_at_most sizes the pool to the limit)",
                        Bytes(fit)
                    )
                } else {
                    "let ShmConfig::pool_size_at_most do without a pool (messages then go from the heap)".to_string()
                };
                return Err(ConfigError {
                    setting: "ShmConfig::pool_size",
                    value: bytes.to_string(),
                    reason: format!(
                        "Zenoh locks shared memory in RAM, and this pool needs {}{} while the process's {memlock} leaves {}: {instead}, or {RAISE_THE_LIMIT}",
                        Bytes(bytes as u64),
                        if own_metadata > 0 {
                            format!(" ({} with Zenoh's {} metadata segment)", Bytes(need), Bytes(own_metadata))
                        } else {
                            String::new()
                        },
                        Bytes(available),
                    ),
                });
            }
            if memlock.available().is_some()
                && available - need < ZENOH_METADATA_SEGMENT + FIT_GRANULE
            {
                tracing::warn!(
                    pool_size = bytes,
                    %memlock,
                    "the shared-memory pool leaves almost no room under the memory-lock limit to map other processes' segments: their messages cannot be read from shared memory by this process"
                );
            }
            Ok(Some(bytes))
        }
    }
}

impl ShmContext {
    /// Whether `other` is this pool (a clone of the same context).
    pub(crate) fn same_pool(&self, other: &ShmContext) -> bool {
        Arc::ptr_eq(&self.inner, &other.inner)
    }

    /// Create a pool. Its size follows [`ShmConfig::pool_size`]: by default as
    /// large as the memory-lock limit allows, up to 10 MiB (no pool at all,
    /// and publishing from the heap, if the limit has no room for one; a log
    /// line says what was chosen and why); an exact size the limit cannot hold
    /// is an error naming the limit and how to raise it. Settings Zenoh would
    /// refuse are refused first ([`ShmConfig::validate`]); a pool the system
    /// cannot provide (e.g. larger than `/dev/shm`) is an error that says so.
    pub fn new(config: ShmConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        // One pool at a time: each is sized from what the others left.
        static CREATING: Mutex<()> = Mutex::new(());
        let _creating = CREATING.lock().unwrap_or_else(|e| e.into_inner());
        let memlock = if config.raise_memlock_limit {
            MemlockBudget::raise_and_read()
        } else {
            MemlockBudget::read()
        };
        let size = size_pool(
            config.pool_size,
            &memlock,
            OWN_METADATA_LOCKED.load(Ordering::Relaxed),
            dev_shm_free(),
        )?;
        let Some(size) = size else {
            tracing::warn!(
                %memlock,
                "no shared-memory pool: the memory-lock limit leaves no room for one, so messages are published from the heap (ShmStats::unavailable counts them); {RAISE_THE_LIMIT}"
            );
            return Ok(Self::with(None, 0, config, memlock));
        };
        if matches!(config.pool_size, PoolSize::AtMost(max) if size < max) {
            tracing::info!(
                pool_size = size,
                %memlock,
                "shared-memory pool sized to the memory-lock limit, leaving as much again to map a peer's pool; ShmConfig::pool_size sets a size, `ulimit -l` raises the limit"
            );
        }
        let provider = PosixShmProviderBackend::builder(size)
            .wait()
            .map(|posix| ShmProviderBuilder::backend(CdrBackend::new(posix)).wait())
            .map_err(|e| {
                let cause =
                    if memlock.available().is_some() && e.to_string().contains("OS error 12") {
                        format!("; the process's {memlock}: {RAISE_THE_LIMIT}")
                    } else {
                        "; check the room in /dev/shm (`df -h /dev/shm`; in Docker, `--shm-size`)"
                            .to_string()
                    };
                ConfigError {
                    setting: "ShmConfig::pool_size",
                    value: size.to_string(),
                    reason: format!(
                        "Zenoh could not create a shared-memory pool of that size ({e}){cause}"
                    ),
                }
            })?;
        if config.threshold > size {
            tracing::warn!(
                threshold = config.threshold,
                pool_size = size,
                "SHM threshold above the pool size: no message will ever use shared memory"
            );
        }
        lock_own_metadata(&provider, size, &memlock)?;
        if config.prefault {
            prefault(&provider, size);
        }
        Ok(Self::with(Some(provider), size, config, memlock))
    }

    fn with(
        provider: Option<ShmProvider<CdrBackend>>,
        size: usize,
        config: ShmConfig,
        memlock: MemlockBudget,
    ) -> Self {
        Self {
            inner: Arc::new(Inner {
                provider,
                size,
                config,
                memlock,
                stats: Counters::default(),
                reach: ReachTable::default(),
            }),
        }
    }

    /// A pool configured from `ZENOH_SHM_ALLOC_SIZE` /
    /// `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD`, or `None` if neither is set.
    pub fn from_env() -> Result<Option<Self>, ConfigError> {
        match ShmConfig::from_env()? {
            Some(config) => Self::new(config).map(Some).map_err(|error| ConfigError {
                // The size came from the environment: name what to change.
                setting: if error.setting == "ShmConfig::pool_size" {
                    ShmConfig::ENV_ALLOC_SIZE
                } else {
                    error.setting
                },
                ..error
            }),
            None => Ok(None),
        }
    }

    /// The settings of this pool.
    pub fn config(&self) -> ShmConfig {
        self.inner.config
    }

    /// The size of the pool in bytes, or `None` if the memory-lock limit left
    /// no room for one (see [`PoolSize::AtMost`]).
    pub fn pool_size(&self) -> Option<usize> {
        self.inner.provider.as_ref().map(|_| self.inner.size)
    }

    /// The memory-lock budget the pool was sized under, as read when it was
    /// created.
    pub fn memlock(&self) -> MemlockBudget {
        self.inner.memlock
    }

    /// The underlying Zenoh provider, to allocate buffers for user-managed fields
    /// (see [`ShmBytes`](crate::ShmBytes)); `None` if there is no pool. Its
    /// chunks requested with an alignment of at most 4 bytes (the default)
    /// start at 4 mod 8, where a CDR message's body is 8-aligned; see
    /// [`CdrBackend`].
    pub fn provider(&self) -> Option<&ShmProvider<CdrBackend>> {
        self.inner.provider.as_ref()
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

    /// What this pool knows of the sessions it has checked.
    pub(crate) fn reach_table(&self) -> &ReachTable {
        &self.inner.reach
    }

    /// Counters since the pool was created.
    pub fn stats(&self) -> ShmStats {
        let c = &self.inner.stats;
        ShmStats {
            shm: c.shm.load(Ordering::Relaxed),
            heap: c.heap.load(Ordering::Relaxed),
            fallbacks: c.fallbacks.load(Ordering::Relaxed),
            too_large: c.too_large.load(Ordering::Relaxed),
            unavailable: c.unavailable.load(Ordering::Relaxed),
            pending: c.pending.load(Ordering::Relaxed),
            cannot_map: c.cannot_map.load(Ordering::Relaxed),
            copied: c.copied.load(Ordering::Relaxed),
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
        let provider = self.inner.provider.as_ref()?;
        if len == 0 || len > self.inner.size {
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
            provider.garbage_collect();
        }
        loop {
            match provider
                .alloc((len, align))
                .with_policy::<Defragment<GarbageCollect>>()
                .wait()
            {
                Ok(buffer) => {
                    // Loaded first: a store on every publish would bounce the
                    // cache line between publishing threads.
                    if !OWN_METADATA_LOCKED.load(Ordering::Relaxed) {
                        OWN_METADATA_LOCKED.store(true, Ordering::Relaxed);
                    }
                    return Some(buffer);
                }
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
    /// watchdog period (100 ms in Zenoh 1.9). This is how a publisher gets back
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
        let Some(provider) = self.inner.provider.as_ref() else {
            return 0;
        };
        // SAFETY: forwarded to the caller (see above); this is exactly Zenoh's
        // contract for `garbage_collect_unsafe`, which frees refcounted chunks
        // only when their watchdog is invalidated.
        let largest = unsafe { provider.garbage_collect_unsafe() };
        provider.defragment();
        tracing::info!(largest, "reclaimed shared memory abandoned by dead readers");
        largest
    }

    /// Shared memory for a message of `size` bytes at or above the threshold,
    /// or the reason it goes from the heap instead.
    pub(crate) fn place(&self, size: usize) -> Result<ZShmMut, PayloadKind> {
        if self.inner.provider.is_none() {
            return Err(PayloadKind::PoolUnavailable);
        }
        if size > self.inner.size {
            return Err(PayloadKind::TooLargeForPool);
        }
        self.alloc_message(size, self.inner.config.alloc_timeout)
            .ok_or(PayloadKind::HeapFallback)
    }

    /// Count a published message of `size` bytes that went as `kind`, warning
    /// where it went from the heap against the settings' intent.
    /// Count a message sent through the pool that a session got as a copy.
    pub(crate) fn count_copied(&self) {
        self.inner.stats.copied.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn count(&self, kind: PayloadKind, size: usize) {
        let c = &self.inner.stats;
        match kind {
            PayloadKind::Shm | PayloadKind::Spliced => {
                c.shm.fetch_add(1, Ordering::Relaxed);
            }
            PayloadKind::Heap => {
                c.heap.fetch_add(1, Ordering::Relaxed);
            }
            PayloadKind::HeapFallback => {
                let n = c.fallbacks.fetch_add(1, Ordering::Relaxed) + 1;
                // The 1st, 2nd, 4th, 8th… time: visible, without a line per message.
                if n.is_power_of_two() {
                    tracing::warn!(
                        size,
                        fallbacks = n,
                        pool_size = self.inner.size,
                        "shared-memory pool exhausted: message published from the heap (ShmContext::stats() counts them)"
                    );
                }
            }
            PayloadKind::TooLargeForPool => {
                if c.too_large.fetch_add(1, Ordering::Relaxed) == 0 {
                    tracing::warn!(
                        size,
                        pool_size = self.inner.size,
                        "message larger than the whole shared-memory pool: it can never fit, so it is published from the heap; enlarge the pool (ShmConfig::pool_size / ZENOH_SHM_ALLOC_SIZE) to send it through shared memory"
                    );
                }
            }
            // Warned about where the check settles (see `reach`).
            PayloadKind::ReceiverPending => {
                c.pending.fetch_add(1, Ordering::Relaxed);
            }
            PayloadKind::ReceiverCannotMap => {
                c.cannot_map.fetch_add(1, Ordering::Relaxed);
            }
            PayloadKind::PoolUnavailable => {
                if c.unavailable.fetch_add(1, Ordering::Relaxed) == 0 {
                    tracing::warn!(
                        size,
                        memlock = %self.inner.memlock,
                        "message above the threshold published from the heap: the memory-lock limit left no room for a shared-memory pool (ShmStats::unavailable counts them); {RAISE_THE_LIMIT}"
                    );
                }
            }
        }
    }
}

/// Bytes free in `/dev/shm`, where POSIX shared memory lives (`None` if it
/// cannot be read).
fn dev_shm_free() -> Option<u64> {
    let stats = nix::sys::statvfs::statvfs("/dev/shm").ok()?;
    #[allow(clippy::useless_conversion)] // the field types differ between targets
    let (blocks, size) = (
        u64::from(stats.blocks_available()),
        u64::from(stats.fragment_size()),
    );
    Some(blocks.saturating_mul(size))
}

/// Make Zenoh create (and lock) this process's metadata segment now, while
/// the budget says there is room for it, rather than in the middle of a later
/// publish: Zenoh creates it on a process's first allocation and panics if it
/// cannot (`zenoh-shm` 1.9 unwraps the error), so a failure here is turned
/// into an error instead.
fn lock_own_metadata(
    provider: &ShmProvider<CdrBackend>,
    size: usize,
    memlock: &MemlockBudget,
) -> Result<(), ConfigError> {
    if OWN_METADATA_LOCKED.load(Ordering::Relaxed) {
        return Ok(());
    }
    let first = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        provider.alloc(8).wait().map(drop)
    }));
    match first {
        Ok(Ok(())) => {
            OWN_METADATA_LOCKED.store(true, Ordering::Relaxed);
            Ok(())
        }
        Ok(Err(error)) => Err(ConfigError {
            setting: "ShmConfig::pool_size",
            value: size.to_string(),
            reason: format!("Zenoh could not allocate from the new pool ({error:?})"),
        }),
        Err(_) => Err(ConfigError {
            setting: "ShmConfig::pool_size",
            value: size.to_string(),
            reason: format!(
                "Zenoh could not create its {} shared-memory metadata segment (the process's {memlock}; free space in /dev/shm: `df -h /dev/shm`): {RAISE_THE_LIMIT}",
                Bytes(ZENOH_METADATA_SEGMENT)
            ),
        }),
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
    if !held.is_empty() {
        OWN_METADATA_LOCKED.store(true, Ordering::Relaxed);
    }
    drop(held);
    provider.garbage_collect();
    provider.defragment();
}

#[cfg(test)]
mod tests {
    use super::*;

    const MIB: u64 = 1 << 20;

    fn limited(limit: u64, locked: u64) -> MemlockBudget {
        MemlockBudget {
            limit: Some(limit),
            exempt: false,
            locked,
        }
    }

    #[test]
    fn a_default_pool_takes_half_of_what_the_limit_leaves_after_two_metadata_segments() {
        let default = PoolSize::AtMost(ShmConfig::DEFAULT_POOL_SIZE);
        // An ordinary user's 8 MiB: (8 - 2 × 1.25 - 0.25) / 2 = 2.625 MiB, so
        // two processes that map each other's pools fit.
        let size = size_pool(default, &limited(8 * MIB, 0), false, None).unwrap();
        assert_eq!(size, Some(2688 * 1024));
        let pair = 2 * (size.unwrap() as u64 + ZENOH_METADATA_SEGMENT);
        assert!(pair <= 8 * MIB, "{pair}");
        // What is locked already is not available; the own metadata segment
        // is counted once.
        let later = size_pool(default, &limited(8 * MIB, 4 * MIB), true, None).unwrap();
        assert_eq!(later, Some(1280 * 1024));
        // 64 KiB, as in many containers: no pool at all.
        assert_eq!(
            size_pool(default, &limited(64 * 1024, 0), false, None),
            Ok(None)
        );
        // Never more than asked for, and all of it when nothing limits.
        assert_eq!(
            size_pool(default, &limited(1 << 40, 0), false, None),
            Ok(Some(ShmConfig::DEFAULT_POOL_SIZE))
        );
        for unlimited in [
            MemlockBudget {
                limit: None,
                exempt: false,
                locked: 0,
            },
            MemlockBudget {
                limit: Some(64 * 1024),
                exempt: true,
                locked: 0,
            },
        ] {
            assert_eq!(
                size_pool(PoolSize::AtMost(1 << 30), &unlimited, false, None),
                Ok(Some(1 << 30))
            );
        }
    }

    #[test]
    fn a_pool_fits_the_room_left_in_dev_shm() {
        let root = MemlockBudget {
            limit: None,
            exempt: true,
            locked: 0,
        };
        // Docker's 64 MiB, half of it taken: a default pool takes half of the
        // rest after the metadata segment.
        let free = Some(32 * MIB);
        let size = size_pool(PoolSize::AtMost(1 << 30), &root, false, free).unwrap();
        assert_eq!(size, Some(15 * MIB as usize + 384 * 1024));
        assert_eq!(
            size_pool(PoolSize::AtMost(4 << 20), &root, false, free),
            Ok(Some(4 << 20))
        );
        assert_eq!(
            size_pool(PoolSize::AtMost(4 << 20), &root, false, Some(64 * 1024)),
            Ok(None)
        );
        // 63 MiB exactly in a 64 MiB /dev/shm: no room for Zenoh's metadata.
        let err = size_pool(PoolSize::Exact(63 << 20), &root, false, Some(64 * MIB)).unwrap_err();
        assert_eq!(err.setting, "ShmConfig::pool_size");
        for needed in [
            "/dev/shm has 64 MiB free",
            "63 MiB",
            "1.25 MiB",
            "--shm-size",
        ] {
            assert!(err.reason.contains(needed), "{needed:?} in {err}");
        }
        assert_eq!(
            size_pool(PoolSize::Exact(62 << 20), &root, false, Some(64 * MIB)),
            Ok(Some(62 << 20))
        );
    }

    #[test]
    fn an_exact_pool_the_limit_cannot_hold_is_an_error_naming_the_limit_and_the_fix() {
        let budget = limited(8 * MIB, 0);
        // 6 MiB fits beside the process's own metadata segment (1.25 MiB)...
        assert_eq!(
            size_pool(PoolSize::Exact(6 << 20), &budget, false, None),
            Ok(Some(6 << 20))
        );
        // ...7 MiB does not, unless that segment is locked already.
        let err = size_pool(PoolSize::Exact(7 << 20), &budget, false, None).unwrap_err();
        assert_eq!(err.setting, "ShmConfig::pool_size");
        for needed in [
            "7 MiB",
            "8.25 MiB",
            "8 MiB (`ulimit -l` 8192)",
            "at most 2.625 MiB",
            "ulimit -l",
            "limits.conf",
            "LimitMEMLOCK=",
            "--ulimit memlock=",
            "--cap-add IPC_LOCK",
        ] {
            assert!(err.reason.contains(needed), "{needed:?} in {err}");
        }
        assert_eq!(
            size_pool(
                PoolSize::Exact(6 << 20),
                &limited(8 * MIB, 3 * MIB),
                true,
                None
            )
            .unwrap_err()
            .setting,
            "ShmConfig::pool_size"
        );
        assert!(size_pool(PoolSize::Exact(7 << 20), &budget, true, None).is_ok());
        // Where no pool fits, the error says that the default does without.
        let err = size_pool(
            PoolSize::Exact(1 << 20),
            &limited(64 * 1024, 0),
            false,
            None,
        )
        .unwrap_err();
        assert!(err.reason.contains("pool_size_at_most"), "{err}");
    }

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
                pool.provider().unwrap().garbage_collect();
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
            pool.provider().unwrap().garbage_collect();
            pool.provider().unwrap().defragment();
            // Everything came back.
            assert_eq!(largest(&pool), fresh, "round {round}");
        }
    }
}
