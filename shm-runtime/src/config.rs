//! Shared-memory settings: off unless enabled; when enabled a 10 MiB pool and a
//! 512-byte threshold, as in rmw_zenoh_cpp and the ROS-Z SHM design.

use std::fmt;
use std::time::Duration;

/// How a publisher uses shared memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShmConfig {
    /// Size of the shared-memory pool in bytes.
    pub pool_size: usize,
    /// Messages of at least this many encoded bytes go through shared memory;
    /// smaller ones are encoded on the heap.
    pub threshold: usize,
    /// How long a publish may wait for the pool to free space (after garbage
    /// collection and defragmentation) before it falls back to the heap.
    pub alloc_timeout: Duration,
}

impl ShmConfig {
    /// rmw_zenoh_cpp's default pool size: 10 MiB.
    pub const DEFAULT_POOL_SIZE: usize = 10 * 1024 * 1024;
    /// rmw_zenoh_cpp's default threshold: 512 bytes.
    pub const DEFAULT_THRESHOLD: usize = 512;
    /// Default bounded wait for pool space before falling back to the heap.
    pub const DEFAULT_ALLOC_TIMEOUT: Duration = Duration::from_millis(5);
    /// Environment variable holding the pool size (setting it enables SHM).
    pub const ENV_ALLOC_SIZE: &'static str = "ZENOH_SHM_ALLOC_SIZE";
    /// Environment variable holding the threshold (setting it enables SHM).
    pub const ENV_THRESHOLD: &'static str = "ZENOH_SHM_MESSAGE_SIZE_THRESHOLD";

    /// SHM enabled with the defaults.
    pub const fn enabled() -> Self {
        Self {
            pool_size: Self::DEFAULT_POOL_SIZE,
            threshold: Self::DEFAULT_THRESHOLD,
            alloc_timeout: Self::DEFAULT_ALLOC_TIMEOUT,
        }
    }

    /// Set the pool size.
    pub const fn pool_size(mut self, bytes: usize) -> Self {
        self.pool_size = bytes;
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

    /// Read `ZENOH_SHM_ALLOC_SIZE` and `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD` as
    /// rmw_zenoh_cpp does: `Ok(None)` if neither is set (SHM off); setting either
    /// enables SHM, the other taking its default. A value that is not a positive
    /// integer is an error, never silently ignored.
    pub fn from_env() -> Result<Option<Self>, ConfigError> {
        Self::from_lookup(|name| std::env::var(name).ok())
    }

    /// [`Self::from_env`] over any variable lookup (for tests and embedding).
    pub fn from_lookup(
        lookup: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<Self>, ConfigError> {
        let parse = |name: &'static str| -> Result<Option<usize>, ConfigError> {
            match lookup(name) {
                None => Ok(None),
                Some(raw) => match raw.trim().parse::<usize>() {
                    Ok(value) if value > 0 => Ok(Some(value)),
                    _ => Err(ConfigError {
                        variable: name,
                        value: raw,
                    }),
                },
            }
        };
        let pool = parse(Self::ENV_ALLOC_SIZE)?;
        let threshold = parse(Self::ENV_THRESHOLD)?;
        if pool.is_none() && threshold.is_none() {
            return Ok(None);
        }
        let mut config = Self::enabled();
        if let Some(pool) = pool {
            config.pool_size = pool;
        }
        if let Some(threshold) = threshold {
            config.threshold = threshold;
        }
        Ok(Some(config))
    }
}

impl Default for ShmConfig {
    fn default() -> Self {
        Self::enabled()
    }
}

/// An SHM environment variable holds something other than a positive integer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// The variable.
    pub variable: &'static str,
    /// Its value.
    pub value: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}={:?} is not a positive number of bytes (unset it to use the default)",
            self.variable, self.value
        )
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
        assert_eq!((c.pool_size, c.threshold), (1 << 20, 512));
        let c = ShmConfig::from_lookup(env(&[("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD", "4096")]))
            .unwrap()
            .unwrap();
        assert_eq!((c.pool_size, c.threshold), (10 << 20, 4096));
    }

    #[test]
    fn invalid_values_are_errors() {
        for bad in ["", "ten", "-1", "0", "1.5", "10MiB"] {
            let err = ShmConfig::from_lookup(env(&[("ZENOH_SHM_ALLOC_SIZE", bad)])).unwrap_err();
            assert_eq!(err.variable, "ZENOH_SHM_ALLOC_SIZE");
            assert!(err.to_string().contains("ZENOH_SHM_ALLOC_SIZE"), "{err}");
        }
        let err = ShmConfig::from_lookup(env(&[
            ("ZENOH_SHM_ALLOC_SIZE", "1024"),
            ("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD", "x"),
        ]))
        .unwrap_err();
        assert_eq!(err.variable, "ZENOH_SHM_MESSAGE_SIZE_THRESHOLD");
    }
}
