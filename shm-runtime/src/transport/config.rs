//! Shared-memory settings: off unless enabled; when enabled a pool of up to
//! 10 MiB that fits the process's memory-lock limit, touched whole when it is
//! made, and rmw_zenoh_cpp's 512-byte threshold.
//!
//! rmw_zenoh_cpp's pool is Zenoh's transport-optimization provider, sized by
//! `transport/shared_memory/transport_optimization/pool_size` in its session
//! configuration: 48 MiB (`50331648`) in the default configuration of every
//! release, Humble to Rolling, and mapped lazily. Its `SHM_BUFFER_SIZE_MB`
//! (10) is defined and never used. Ours is smaller by default because it is
//! committed when it is made, in every process that publishes.

use std::fmt;
use std::time::Duration;

/// How a publisher uses shared memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShmConfig {
    /// Size of the shared-memory pool: as large as the memory-lock limit
    /// allows up to a maximum (the default), or exactly a number of bytes.
    pub pool_size: PoolSize,
    /// Messages of at least this many encoded bytes go through shared memory;
    /// smaller ones are encoded on the heap.
    pub threshold: usize,
    /// How long a publish may wait for the pool to free space (after garbage
    /// collection and defragmentation) before it falls back to the heap.
    pub alloc_timeout: Duration,
    /// Touch every page of the pool when it is created (the default), so that
    /// publishing never pays first-touch page faults (about 60 µs per fresh
    /// MiB). It commits the whole pool at creation and takes time: creating a
    /// pool took (medians of 5, release build, 2 busy cores) 5.4 ms for 10 MiB
    /// and 0.71 s for 1 GiB with it, 3.4 ms and 0.48 s without (the rest is
    /// Zenoh's own set-up of the segment).
    pub prefault: bool,
    /// Raise the process's soft memory-lock limit to its hard limit before
    /// sizing the pool (the default, logged at info level): the soft limit is
    /// all the kernel checks, and any process may raise it that far.
    pub raise_memlock_limit: bool,
}

/// How large a shared-memory pool to create.
///
/// Zenoh locks every shared-memory segment in RAM (`mlock`), both the pools a
/// process creates and those it maps to read other processes' messages, so
/// the process's memory-lock limit (`ulimit -l`; 8 MiB for an ordinary user on
/// most Linux systems) bounds them all; see [`MemlockBudget`](crate::MemlockBudget).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum PoolSize {
    /// As large as the memory-lock limit allows, at most this many bytes: half
    /// of what the limit leaves after Zenoh's metadata segments (the
    /// process's own and one it maps from a peer) and 256 KiB for the rest
    /// it locks, so that a peer's pool of the same size can be mapped too;
    /// 2.625 MiB under an 8 MiB limit. Where
    /// that is under [`ShmConfig::MIN_FIT_POOL_SIZE`] there is no pool and
    /// messages go from the heap, counted in
    /// [`ShmStats::unavailable`](crate::ShmStats). Without a limit (root,
    /// `CAP_IPC_LOCK`, `ulimit -l unlimited`) the pool is this size.
    AtMost(usize),
    /// Exactly this many bytes. A pool the memory-lock limit cannot hold is
    /// an error naming the limit, the sizes and how to raise it.
    Exact(usize),
}

impl PoolSize {
    /// The size asked for: the maximum, or the exact size.
    pub const fn requested(self) -> usize {
        match self {
            Self::AtMost(bytes) | Self::Exact(bytes) => bytes,
        }
    }
}

impl ShmConfig {
    /// The default maximum pool size, 10 MiB (rmw_zenoh_cpp's pool is
    /// 48 MiB, mapped lazily; see the module's documentation).
    pub const DEFAULT_POOL_SIZE: usize = 10 * 1024 * 1024;
    /// rmw_zenoh_cpp's default threshold: 512 bytes.
    pub const DEFAULT_THRESHOLD: usize = 512;
    /// Default bounded wait for pool space before falling back to the heap.
    pub const DEFAULT_ALLOC_TIMEOUT: Duration = Duration::from_millis(5);
    /// Environment variable holding the pool size (setting it enables SHM).
    pub const ENV_ALLOC_SIZE: &'static str = "ZENOH_SHM_ALLOC_SIZE";
    /// Environment variable holding the threshold (setting it enables SHM).
    pub const ENV_THRESHOLD: &'static str = "ZENOH_SHM_MESSAGE_SIZE_THRESHOLD";
    /// The smallest pool Zenoh 1.9's allocator accepts (1 KiB fails, 2 KiB
    /// works; a page keeps a margin).
    pub const MIN_POOL_SIZE: usize = 4096;
    /// The largest pool Zenoh 1.9 accepts: its chunk index is 32 bits.
    pub const MAX_POOL_SIZE: usize = 1 << 32;
    /// Below this, a [`PoolSize::AtMost`] pool is not created at all: it could
    /// hold no more than a few small messages.
    pub const MIN_FIT_POOL_SIZE: usize = 64 * 1024;

    /// SHM enabled with the defaults: a pool of up to 10 MiB that fits the
    /// memory-lock limit, a 512-byte threshold.
    pub const fn enabled() -> Self {
        Self {
            pool_size: PoolSize::AtMost(Self::DEFAULT_POOL_SIZE),
            threshold: Self::DEFAULT_THRESHOLD,
            alloc_timeout: Self::DEFAULT_ALLOC_TIMEOUT,
            prefault: true,
            raise_memlock_limit: true,
        }
    }

    /// Whether to touch every page of the pool at creation (default `true`; see
    /// [`ShmConfig::prefault`](#structfield.prefault)).
    pub const fn prefault(mut self, on: bool) -> Self {
        self.prefault = on;
        self
    }

    /// Whether to raise the soft memory-lock limit to the hard one before
    /// sizing the pool (default `true`; see
    /// [`ShmConfig::raise_memlock_limit`](#structfield.raise_memlock_limit)).
    pub const fn raise_memlock_limit(mut self, on: bool) -> Self {
        self.raise_memlock_limit = on;
        self
    }

    /// Check the settings against what Zenoh accepts, so that a bad value is
    /// refused with its name and the valid range rather than by Zenoh's
    /// allocator. [`ShmContext::new`](crate::ShmContext::new) calls it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let size = self.pool_size.requested();
        if !(Self::MIN_POOL_SIZE..=Self::MAX_POOL_SIZE).contains(&size) {
            return Err(ConfigError {
                setting: "ShmConfig::pool_size",
                value: size.to_string(),
                reason: format!(
                    "the pool size must be between {} bytes and {} bytes (4 GiB), Zenoh's limits",
                    Self::MIN_POOL_SIZE,
                    Self::MAX_POOL_SIZE
                ),
            });
        }
        Ok(())
    }

    /// A pool of exactly `bytes` ([`PoolSize::Exact`]).
    pub const fn pool_size(mut self, bytes: usize) -> Self {
        self.pool_size = PoolSize::Exact(bytes);
        self
    }

    /// A pool as large as the memory-lock limit allows, at most `bytes`
    /// ([`PoolSize::AtMost`]).
    pub const fn pool_size_at_most(mut self, bytes: usize) -> Self {
        self.pool_size = PoolSize::AtMost(bytes);
        self
    }

    /// Set the threshold.
    pub const fn threshold(mut self, bytes: usize) -> Self {
        self.threshold = bytes;
        self
    }

    /// Set the bounded wait for pool space.
    pub const fn alloc_timeout(mut self, timeout: Duration) -> Self {
        self.alloc_timeout = timeout;
        self
    }

    /// Read `ZENOH_SHM_ALLOC_SIZE` and `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD`, the
    /// variables rmw_zenoh_cpp reads in place of its session configuration's
    /// pool size and threshold: `Ok(None)` if neither is set (SHM off);
    /// setting either enables SHM here (rmw_zenoh_cpp enables it by its
    /// configuration alone), the other taking its default. A pool size set this way is
    /// exact ([`PoolSize::Exact`]). A value that is not a positive integer is an
    /// error, never silently ignored.
    pub fn from_env() -> Result<Option<Self>, ConfigError> {
        Self::from_lookup(|name| std::env::var(name).ok())
    }

    /// These settings with `ZENOH_SHM_ALLOC_SIZE` and
    /// `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD` applied where they are set: the one
    /// way to build a configuration that the environment can adjust. A value
    /// that is not a positive integer is an error.
    ///
    /// ```no_run
    /// use shm_runtime::{ShmConfig, ShmContext};
    ///
    /// let shm = ShmContext::new(ShmConfig::enabled().with_env()?)?;
    /// # Ok::<(), shm_runtime::ConfigError>(())
    /// ```
    pub fn with_env(self) -> Result<Self, ConfigError> {
        self.with_lookup(|name| std::env::var(name).ok())
    }

    /// [`Self::with_env`] over any variable lookup (for tests and embedding).
    pub fn with_lookup(
        mut self,
        lookup: impl Fn(&str) -> Option<String>,
    ) -> Result<Self, ConfigError> {
        let (pool, threshold) = Self::variables(lookup)?;
        if let Some(pool) = pool {
            self.pool_size = PoolSize::Exact(pool);
        }
        if let Some(threshold) = threshold {
            self.threshold = threshold;
        }
        Ok(self)
    }

    /// [`Self::from_env`] over any variable lookup (for tests and embedding).
    pub fn from_lookup(
        lookup: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<Self>, ConfigError> {
        let (pool, threshold) = Self::variables(&lookup)?;
        if pool.is_none() && threshold.is_none() {
            return Ok(None);
        }
        Self::enabled().with_lookup(lookup).map(Some)
    }

    /// The pool size and threshold the variables set, each checked.
    fn variables(
        lookup: impl Fn(&str) -> Option<String>,
    ) -> Result<(Option<usize>, Option<usize>), ConfigError> {
        let parse = |name: &'static str, min: usize, max: usize| {
            match lookup(name) {
            None => Ok(None),
            Some(raw) => match raw.trim().parse::<usize>() {
                Ok(value) if (min..=max).contains(&value) => Ok(Some(value)),
                _ => Err(ConfigError {
                    setting: name,
                    value: raw,
                    reason: format!(
                        "expected a number of bytes from {min} to {max} (unset it to use the default)"
                    ),
                }),
            },
        }
        };
        let pool = parse(
            Self::ENV_ALLOC_SIZE,
            Self::MIN_POOL_SIZE,
            Self::MAX_POOL_SIZE,
        )?;
        let threshold = parse(Self::ENV_THRESHOLD, 1, Self::MAX_POOL_SIZE)?;
        Ok((pool, threshold))
    }
}

impl Default for ShmConfig {
    fn default() -> Self {
        Self::enabled()
    }
}

/// A shared-memory setting that cannot work: which one, its value, and why.
/// `Debug` prints the same sentence as `Display`, since `main() -> Result`
/// shows errors with `Debug`.
#[derive(Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// The setting: an environment variable (`ZENOH_SHM_ALLOC_SIZE`) or a field
    /// (`ShmConfig::pool_size`).
    pub setting: &'static str,
    /// Its value.
    pub value: String,
    /// What is wrong and what would work.
    pub reason: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={:?}: {}", self.setting, self.value, self.reason)
    }
}

impl fmt::Debug for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for ConfigError {}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn unset_means_off() {
        assert_eq!(ShmConfig::from_lookup(env(&[])).unwrap(), None);
    }

    #[test]
    fn either_variable_enables_with_the_other_default() {
        let c = ShmConfig::from_lookup(env(&[("ZENOH_SHM_ALLOC_SIZE", "1048576")]))
            .unwrap()
            .unwrap();
        assert_eq!((c.pool_size, c.threshold), (PoolSize::Exact(1 << 20), 512));
        let c = ShmConfig::from_lookup(env(&[("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD", "4096")]))
            .unwrap()
            .unwrap();
        assert_eq!(
            (c.pool_size, c.threshold),
            (PoolSize::AtMost(10 << 20), 4096)
        );
    }

    #[test]
    fn the_environment_adjusts_a_configuration_where_set() {
        let base = ShmConfig::enabled()
            .threshold(4096)
            .pool_size_at_most(1 << 20);
        assert_eq!(base.with_lookup(env(&[])).unwrap(), base);
        let c = base
            .with_lookup(env(&[("ZENOH_SHM_ALLOC_SIZE", "2097152")]))
            .unwrap();
        assert_eq!((c.pool_size, c.threshold), (PoolSize::Exact(2 << 20), 4096));
        let c = base
            .with_lookup(env(&[("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD", "100")]))
            .unwrap();
        assert_eq!((c.pool_size, c.threshold), (PoolSize::AtMost(1 << 20), 100));
        let err = base
            .with_lookup(env(&[("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD", "lots")]))
            .unwrap_err();
        assert_eq!(err.setting, "ZENOH_SHM_MESSAGE_SIZE_THRESHOLD");
    }

    #[test]
    fn invalid_values_are_errors() {
        for bad in [
            "",
            "ten",
            "-1",
            "0",
            "1",
            "1024",
            "1.5",
            "10MiB",
            "18446744073709551615",
            "8589934592",
        ] {
            let err = ShmConfig::from_lookup(env(&[("ZENOH_SHM_ALLOC_SIZE", bad)])).unwrap_err();
            assert_eq!(err.setting, "ZENOH_SHM_ALLOC_SIZE");
            assert!(err.to_string().contains("ZENOH_SHM_ALLOC_SIZE"), "{err}");
            assert!(err.to_string().contains("4294967296"), "{err}");
            // `main() -> Result` prints Debug: it must be the sentence too.
            assert_eq!(format!("{err:?}"), err.to_string());
        }
        let err = ShmConfig::from_lookup(env(&[
            ("ZENOH_SHM_ALLOC_SIZE", "1048576"),
            ("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD", "x"),
        ]))
        .unwrap_err();
        assert_eq!(err.setting, "ZENOH_SHM_MESSAGE_SIZE_THRESHOLD");
    }

    #[test]
    fn pool_sizes_zenoh_refuses_are_refused_first() {
        for bad in [0, 1, 1024, 4095, (1 << 32) + 1, usize::MAX] {
            let err = ShmConfig::enabled().pool_size(bad).validate().unwrap_err();
            assert_eq!(err.setting, "ShmConfig::pool_size");
        }
        for good in [4096, 10 << 20, 1 << 32] {
            ShmConfig::enabled().pool_size(good).validate().unwrap();
            ShmConfig::enabled()
                .pool_size_at_most(good)
                .validate()
                .unwrap();
        }
        let err = ShmConfig::enabled()
            .pool_size_at_most(1024)
            .validate()
            .unwrap_err();
        assert_eq!(err.setting, "ShmConfig::pool_size");
    }
}
