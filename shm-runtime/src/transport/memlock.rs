//! The memory-lock budget shared memory runs under.
//!
//! Zenoh 1.9 `mlock`s every shared-memory segment a process touches: the pool
//! it creates, the per-process metadata segment that holds its chunks'
//! reference counts, and every segment (pool and metadata) it maps to read
//! another process's messages. What the process may lock is its
//! `RLIMIT_MEMLOCK`: 8 MiB by default for an ordinary user since Linux 5.16,
//! often 64 KiB in containers and CI runners. Root, or any process with
//! `CAP_IPC_LOCK`, is not limited. Pools are sized from this budget (see
//! [`PoolSize::FitMemlock`](crate::PoolSize::FitMemlock)), and a pool that
//! cannot fit is refused with the numbers and the fix.

use std::fmt;
use std::sync::Once;

use rlimit::Resource;

/// What Zenoh locks for a process's own metadata segment, once, when it first
/// allocates shared memory: 32 768 chunk headers of 32 bytes and as many 8-byte
/// watchdogs (`zenoh-shm` 1.9's `MetadataSegment`). A reader locks as much
/// again for each publishing process whose messages it maps.
pub const ZENOH_METADATA_SEGMENT: u64 = 32_768 * (32 + 8);

/// The `CAP_IPC_LOCK` bit of the Linux capability sets.
const CAP_IPC_LOCK: u32 = 14;

/// How much memory this process may lock, and how much it already has.
///
/// ```
/// let budget = shm_runtime::MemlockBudget::read();
/// match budget.available() {
///     None => println!("no memory-lock limit ({budget})"),
///     Some(bytes) => println!("{bytes} bytes may still be locked ({budget})"),
/// }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemlockBudget {
    /// The soft `RLIMIT_MEMLOCK` in bytes, after raising it to the hard limit;
    /// `None` if unlimited.
    pub limit: Option<u64>,
    /// Whether the process has `CAP_IPC_LOCK` (root has it), which exempts it
    /// from the limit.
    pub exempt: bool,
    /// Bytes the process has locked already (`VmLck` in `/proc/self/status`).
    pub locked: u64,
}

impl MemlockBudget {
    /// Read the budget of this process as it stands.
    pub fn read() -> Self {
        let limit = match rlimit::getrlimit(Resource::MEMLOCK) {
            Ok((soft, _)) if soft != rlimit::INFINITY => Some(soft),
            // Unlimited, or a platform without the limit.
            _ => None,
        };
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        Self {
            limit,
            exempt: has_ipc_lock(&status),
            locked: locked_bytes(&status),
        }
    }

    /// Raise the soft `RLIMIT_MEMLOCK` to the hard one (once per process, as
    /// Zenoh raises the open-files limit), then [`read`](Self::read) the
    /// budget. The soft limit is all the kernel checks, and any process may
    /// raise it that far. [`ShmContext::new`](crate::ShmContext::new) does
    /// this unless [`ShmConfig::raise_memlock_limit`](crate::ShmConfig) is off.
    pub fn raise_and_read() -> Self {
        static RAISE: Once = Once::new();
        RAISE.call_once(|| {
            let Ok((soft, hard)) = rlimit::getrlimit(Resource::MEMLOCK) else {
                return;
            };
            if soft >= hard {
                return;
            }
            match rlimit::setrlimit(Resource::MEMLOCK, hard, hard) {
                Ok(()) => tracing::info!(
                    from = soft,
                    to = hard,
                    "raised the soft memory-lock limit (RLIMIT_MEMLOCK) to the hard one for shared memory (ShmConfig::raise_memlock_limit(false) keeps it)"
                ),
                Err(error) => tracing::debug!(%error, soft, hard, "could not raise RLIMIT_MEMLOCK to its hard limit"),
            }
        });
        Self::read()
    }

    /// Bytes that may still be locked, or `None` if locking is not limited.
    pub fn available(&self) -> Option<u64> {
        match self.limit {
            Some(limit) if !self.exempt => Some(limit.saturating_sub(self.locked)),
            _ => None,
        }
    }
}

impl fmt::Display for MemlockBudget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.limit, self.exempt) {
            (_, true) => write!(f, "memory-lock limit does not apply (CAP_IPC_LOCK)"),
            (None, false) => write!(f, "memory-lock limit unlimited"),
            (Some(limit), false) => write!(
                f,
                "memory-lock limit (RLIMIT_MEMLOCK) {} (`ulimit -l` {}), {} locked already",
                Bytes(limit),
                limit / 1024,
                Bytes(self.locked)
            ),
        }
    }
}

/// How to raise the limit, for error messages.
pub(crate) const RAISE_THE_LIMIT: &str = "raise the memory-lock limit (RLIMIT_MEMLOCK): `ulimit -l <KiB>` in the shell that starts the program (up to the hard limit, `ulimit -Hl`), `<user> - memlock <KiB>` in /etc/security/limits.conf, `LimitMEMLOCK=` in a systemd unit, `--ulimit memlock=<bytes>` (`-1`: unlimited) or `--cap-add IPC_LOCK` for Docker";

/// A byte count printed in the unit that reads best.
pub(crate) struct Bytes(pub(crate) u64);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const KIB: u64 = 1024;
        const MIB: u64 = 1024 * 1024;
        match self.0 {
            n if n >= MIB && n % (MIB / 16) == 0 => write!(f, "{} MiB", n as f64 / MIB as f64),
            n if n >= MIB => write!(f, "{:.2} MiB", n as f64 / MIB as f64),
            n if n >= KIB && n % KIB == 0 => write!(f, "{} KiB", n / KIB),
            n => write!(f, "{n} bytes"),
        }
    }
}

/// Whether `CapEff` in a `/proc/<pid>/status` text has `CAP_IPC_LOCK`.
fn has_ipc_lock(status: &str) -> bool {
    field(status, "CapEff:")
        .and_then(|hex| u64::from_str_radix(hex, 16).ok())
        .is_some_and(|caps| caps & (1 << CAP_IPC_LOCK) != 0)
}

/// `VmLck` of a `/proc/<pid>/status` text, in bytes (0 if absent).
fn locked_bytes(status: &str) -> u64 {
    field(status, "VmLck:")
        .and_then(|kib| kib.trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or(0, |kib| kib.saturating_mul(1024))
}

fn field<'s>(status: &'s str, name: &str) -> Option<&'s str> {
    status
        .lines()
        .find_map(|line| line.strip_prefix(name))
        .map(str::trim)
}

#[cfg(test)]
mod tests {
    use super::*;

    const STATUS: &str = "Name:\tx\nVmLck:\t    1280 kB\nCapEff:\t000001ffffffffff\n";

    #[test]
    fn status_fields_are_read() {
        assert!(has_ipc_lock(STATUS));
        assert!(!has_ipc_lock("CapEff:\t0000000000000000\n"));
        assert!(!has_ipc_lock(
            "CapEff:\t0000000000000000\n".replace('0', "z").as_str()
        ));
        assert!(!has_ipc_lock(""));
        assert_eq!(locked_bytes(STATUS), 1280 * 1024);
        assert_eq!(locked_bytes("VmLck: lots\n"), 0);
        assert_eq!(locked_bytes(""), 0);
    }

    #[test]
    fn available_is_the_limit_less_what_is_locked_unless_exempt() {
        let budget = MemlockBudget {
            limit: Some(8 << 20),
            exempt: false,
            locked: 1 << 20,
        };
        assert_eq!(budget.available(), Some(7 << 20));
        assert!(
            budget.to_string().contains("8 MiB (`ulimit -l` 8192)"),
            "{budget}"
        );
        let over = MemlockBudget {
            locked: 9 << 20,
            ..budget
        };
        assert_eq!(over.available(), Some(0));
        let root = MemlockBudget {
            exempt: true,
            ..budget
        };
        assert_eq!(root.available(), None);
        let unlimited = MemlockBudget {
            limit: None,
            ..budget
        };
        assert_eq!(unlimited.available(), None);
    }

    #[test]
    fn sizes_print_in_their_unit() {
        assert_eq!(Bytes(8 << 20).to_string(), "8 MiB");
        assert_eq!(Bytes(2_883_584).to_string(), "2.75 MiB");
        assert_eq!(Bytes(1_310_720).to_string(), "1.25 MiB");
        assert_eq!(Bytes(1_000_000).to_string(), "1000000 bytes");
        assert_eq!(Bytes(65536).to_string(), "64 KiB");
    }
}
