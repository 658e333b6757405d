//! The Zenoh line this program was built with, and which lines share memory.
//!
//! The runtime accepts every Zenoh line it is tested on; the application's
//! lock file picks one. Two Zenoh sessions share memory only when their
//! shared-memory protocols match: 1.8 and 1.9 speak protocol 1 (the 1.8 of
//! every rmw_zenoh_cpp release among them), 1.10 speaks protocol 2 and copies
//! every shared-memory message into a transport to an older line.

use std::fmt;

/// A Zenoh release line: `1.9` for every 1.9.x release.
///
/// ```
/// use shm_runtime::ZenohLine;
///
/// let built = ZenohLine::BUILT;
/// println!("Zenoh {built}, shared-memory protocol {}", ZenohLine::BUILT_SHM_PROTOCOL);
/// // rmw_zenoh_cpp's nodes (Zenoh 1.8) map this program's buffers only on a
/// // line that speaks their shared-memory protocol.
/// let with_ros = built.shares_memory_with(ZenohLine::new(1, 8));
/// assert_eq!(with_ros, Some(ZenohLine::BUILT_SHM_PROTOCOL == 1));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ZenohLine {
    /// The major version.
    pub major: u16,
    /// The minor version.
    pub minor: u16,
}

/// Each line the runtime is tested on, with its shared-memory protocol
/// (`zenoh_shm::version::SHM_VERSION` of its releases).
const KNOWN: &[(ZenohLine, u64)] = &[
    (ZenohLine::new(1, 8), 1),
    (ZenohLine::new(1, 9), 1),
    (ZenohLine::new(1, 10), 2),
];

impl ZenohLine {
    /// The line of the Zenoh this program was built with (from
    /// `zenoh::GIT_VERSION`, which the application's lock file chose).
    pub const BUILT: ZenohLine = match parse_git_version(zenoh::GIT_VERSION) {
        Some(line) => line,
        None => panic!("zenoh::GIT_VERSION does not start with v<major>.<minor>"),
    };

    /// The shared-memory protocol of the Zenoh this program was built with:
    /// sessions share memory only with sessions speaking the same one.
    pub const BUILT_SHM_PROTOCOL: u64 = zenoh_shm::version::SHM_VERSION;

    /// Every line the runtime is built and tested on, oldest first.
    pub const SUPPORTED: [ZenohLine; 3] = [KNOWN[0].0, KNOWN[1].0, KNOWN[2].0];

    /// The line `major.minor`.
    pub const fn new(major: u16, minor: u16) -> Self {
        Self { major, minor }
    }

    /// The line of a version such as `"1.8.0"` or `"v1.10.2-abc"`; `None` if it
    /// does not start with `<major>.<minor>`.
    pub fn parse(version: &str) -> Option<Self> {
        parse_git_version(version)
    }

    /// The shared-memory protocol this line speaks, if it is one the runtime
    /// knows ([`SUPPORTED`](Self::SUPPORTED)).
    pub fn shm_protocol(self) -> Option<u64> {
        if self == Self::BUILT {
            return Some(Self::BUILT_SHM_PROTOCOL);
        }
        KNOWN
            .iter()
            .find(|(line, _)| *line == self)
            .map(|&(_, protocol)| protocol)
    }

    /// Whether sessions on this line and on `other` share memory (same host,
    /// same user, shared memory on in both): `None` if either line is unknown.
    pub fn shares_memory_with(self, other: ZenohLine) -> Option<bool> {
        Some(self.shm_protocol()? == other.shm_protocol()?)
    }
}

impl fmt::Display for ZenohLine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.major, self.minor)
    }
}

/// Why a session on this host may be linked without shared memory, as far as
/// Zenoh lines go: which lines speak another protocol than this program's.
pub(crate) fn other_lines_hint() -> String {
    let others: Vec<String> = KNOWN
        .iter()
        .filter(|(line, _)| ZenohLine::BUILT.shares_memory_with(*line) == Some(false))
        .map(|(line, _)| line.to_string())
        .collect();
    let others = match others.len() {
        0 => String::new(),
        1 => format!("; Zenoh {} speaks another", others[0]),
        _ => format!("; Zenoh {} speak another", others.join(" and ")),
    };
    let ros = if ZenohLine::BUILT.shares_memory_with(ZenohLine::new(1, 8)) == Some(false) {
        ", the 1.8 of every rmw_zenoh_cpp release among them"
    } else {
        ""
    };
    format!(
        "Its Zenoh may speak another shared-memory protocol than this program's Zenoh {} (protocol {}{}{})",
        ZenohLine::BUILT,
        ZenohLine::BUILT_SHM_PROTOCOL,
        others,
        ros
    )
}

/// `major.minor` at the start of `version`, after an optional `v`.
const fn parse_git_version(version: &str) -> Option<ZenohLine> {
    let bytes = version.as_bytes();
    let mut at = 0;
    if !bytes.is_empty() && bytes[0] == b'v' {
        at = 1;
    }
    let (major, next) = match parse_number(bytes, at) {
        Some(parsed) => parsed,
        None => return None,
    };
    if next >= bytes.len() || bytes[next] != b'.' {
        return None;
    }
    let (minor, _) = match parse_number(bytes, next + 1) {
        Some(parsed) => parsed,
        None => return None,
    };
    Some(ZenohLine::new(major, minor))
}

/// A decimal number of at most 4 digits at `at`, and where it ends.
const fn parse_number(bytes: &[u8], mut at: usize) -> Option<(u16, usize)> {
    let start = at;
    let mut value: u16 = 0;
    while at < bytes.len() && bytes[at].is_ascii_digit() && at - start < 4 {
        value = value * 10 + (bytes[at] - b'0') as u16;
        at += 1;
    }
    if at == start {
        None
    } else {
        Some((value, at))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_parse_into_their_line() {
        assert_eq!(
            ZenohLine::parse("v1.10.2-4fd8a1c"),
            Some(ZenohLine::new(1, 10))
        );
        assert_eq!(ZenohLine::parse("1.8.0"), Some(ZenohLine::new(1, 8)));
        assert_eq!(ZenohLine::parse("v1"), None);
        assert_eq!(ZenohLine::parse("1."), None);
        assert_eq!(ZenohLine::parse(""), None);
        assert_eq!(ZenohLine::parse("v99999.1"), None);
        assert_eq!(ZenohLine::new(1, 10).to_string(), "1.10");
        assert!(ZenohLine::new(1, 10) > ZenohLine::new(1, 9));
    }

    #[test]
    fn the_hint_names_the_lines_that_cannot_share_with_this_one() {
        let hint = other_lines_hint();
        assert!(
            hint.contains(&format!("Zenoh {} (protocol", ZenohLine::BUILT)),
            "{hint}"
        );
        for line in ZenohLine::SUPPORTED {
            let named = hint.contains(&format!(" {line} ")) || hint.contains(&format!(" {line}; "));
            let shares = ZenohLine::BUILT.shares_memory_with(line) == Some(true);
            assert_eq!(named && line != ZenohLine::BUILT, !shares, "{line}: {hint}");
        }
    }

    #[test]
    fn lines_share_memory_by_protocol() {
        let (l18, l19, l110) = (
            ZenohLine::new(1, 8),
            ZenohLine::new(1, 9),
            ZenohLine::new(1, 10),
        );
        assert_eq!(l18.shares_memory_with(l19), Some(true));
        assert_eq!(l19.shares_memory_with(l110), Some(false));
        assert_eq!(l110.shares_memory_with(l110), Some(true));
        assert_eq!(l110.shares_memory_with(ZenohLine::new(2, 0)), None);
    }
}
