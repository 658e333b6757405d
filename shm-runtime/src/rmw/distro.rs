//! What differs between the ROS 2 distributions' rmw_zenoh_cpp releases, in
//! one place. Each fact is read from that distribution's released source
//! (`ros2-gbp/rmw_zenoh-release`, tags `release/<distro>/rmw_zenoh_cpp/<version>`):
//!
//! - **Keys, tokens, QoS text, attachment, GIDs** are the same in all five
//!   (`liveliness_utils.cpp`, `qos.cpp`, `attachment_helpers.cpp`), except
//!   that Humble has no type hashes: its publishers, subscribers, servers and
//!   clients write `TypeHashNotSupported` where the others write the RIHS01
//!   hash (`rmw_publisher_data.cpp` and its siblings), in the data key and in
//!   the token. Humble also writes the QoS policies with `std::to_string`
//!   where later releases look them up in a table; the text is the same.
//! - **Jazzy and Kilted** (0.2.10, 0.6.7) differ only in tracing.
//! - **Lyrical and Rolling** (0.10.5, 0.12.0) add `rosidl::Buffer`-aware
//!   endpoints for types with a `uint8[]` field of their own: their tokens
//!   may end in one more field, `backends:<name>:<metadata>;…`, which older
//!   releases ignore. Their subscribers keep the topic's key; their volatile
//!   publishers, while they match no more subscribers than they discovered,
//!   send each message once on `<key>/_buf_cpu`, shared by the subscribers
//!   whose only backend is `cpu`, and on `<key>/_buf/<GID>` for each other one
//!   ([`buffer_key_expr`](super::buffer_key_expr)), which our subscribers of
//!   such types read too; with no subscriber discovered they put nothing, not
//!   even on the topic's key (`rmw_publisher_data.cpp`,
//!   `publish_buffer_aware`). A subscriber once discovered is never
//!   forgotten: they keep putting on its key after it leaves.
//! - **Node services**: `~/get_type_description` exists from Iron on, so a
//!   Humble node has none; logger-level services likewise.

use std::fmt;

use crate::ZenohLine;

/// The type-hash field of Humble's keys and tokens.
pub const TYPE_HASH_NOT_SUPPORTED: &str = "TypeHashNotSupported";

/// A ROS 2 distribution with an rmw_zenoh_cpp release: whose conventions a
/// node speaks and whose interface definitions it uses.
///
/// ```
/// use shm_runtime::rmw::Distro;
///
/// assert_eq!("jazzy".parse::<Distro>(), Ok(Distro::Jazzy));
/// assert_eq!(Distro::Humble.hash_field("RIHS01_ab"), "TypeHashNotSupported");
/// assert_eq!(Distro::Kilted.hash_field("RIHS01_ab"), "RIHS01_ab");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[non_exhaustive]
pub enum Distro {
    /// Humble Hawksbill (rmw_zenoh_cpp 0.1.9): no type hashes.
    Humble,
    /// Jazzy Jalisco (0.2.10).
    Jazzy,
    /// Kilted Kaiju (0.6.7): the default.
    Kilted,
    /// Lyrical Luth (0.10.5): buffer-aware endpoints.
    Lyrical,
    /// Rolling Ridley (0.12.0): as Lyrical.
    Rolling,
}

impl Distro {
    /// Every distribution, oldest first.
    pub const ALL: [Self; 5] = [
        Self::Humble,
        Self::Jazzy,
        Self::Kilted,
        Self::Lyrical,
        Self::Rolling,
    ];

    /// The distribution a node speaks unless told otherwise (by
    /// `ROS_DISTRO` or explicitly): Kilted.
    pub const DEFAULT: Self = Self::Kilted;

    /// The distribution `ROS_DISTRO` names, as ROS tools read it; [`DEFAULT`](Self::DEFAULT)
    /// if it is unset or empty. A name that is not one of [`ALL`](Self::ALL)
    /// is an error naming what to set.
    pub fn from_env() -> Result<Self, UnknownDistro> {
        match std::env::var("ROS_DISTRO") {
            Ok(name) if !name.trim().is_empty() => {
                name.parse().map_err(|e: UnknownDistro| UnknownDistro {
                    source: "ROS_DISTRO",
                    ..e
                })
            }
            _ => Ok(Self::DEFAULT),
        }
    }

    /// The lower-case name, as `ROS_DISTRO` writes it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Humble => "humble",
            Self::Jazzy => "jazzy",
            Self::Kilted => "kilted",
            Self::Lyrical => "lyrical",
            Self::Rolling => "rolling",
        }
    }

    /// The rmw_zenoh_cpp release whose conventions this follows, and the
    /// Zenoh it is built on.
    pub fn release(self) -> &'static Distribution {
        // Every distro has its row: `DISTRIBUTIONS` lists `ALL` in order.
        &DISTRIBUTIONS[self as usize]
    }

    /// Whether its keys and tokens carry RIHS01 type hashes (all but Humble).
    pub const fn has_type_hashes(self) -> bool {
        !matches!(self, Self::Humble)
    }

    /// The type-hash field of a key or token for a type whose RIHS01 hash is
    /// `hash`: the hash, or [`TYPE_HASH_NOT_SUPPORTED`] on Humble.
    pub fn hash_field(self, hash: &str) -> &str {
        if self.has_type_hashes() {
            hash
        } else {
            TYPE_HASH_NOT_SUPPORTED
        }
    }

    /// Whether a node of this distribution serves `~/get_type_description`
    /// (rcl's type description service, from Iron on).
    pub const fn has_type_description_service(self) -> bool {
        self.has_type_hashes()
    }

    /// Whether a node of this distribution can serve `~/get_logger_levels`
    /// and `~/set_logger_levels` (`rcl_interfaces` has them from Iron on).
    pub const fn has_logger_level_services(self) -> bool {
        self.has_type_hashes()
    }

    /// Whether its `lifecycle_msgs/msg/TransitionEvent` carries a
    /// `builtin_interfaces/Time stamp` (Lyrical on) rather than a `uint64
    /// timestamp`: [`shm_cdr::distro_msgs`] lists each standard type a
    /// distribution defines differently.
    pub const fn has_stamped_transition_events(self) -> bool {
        matches!(self, Self::Lyrical | Self::Rolling)
    }

    /// Whether its endpoints of types with `rosidl::Buffer` fields may be
    /// buffer-aware (the optional `backends:` token field).
    pub const fn has_buffer_aware_endpoints(self) -> bool {
        matches!(self, Self::Lyrical | Self::Rolling)
    }
}

impl Default for Distro {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl fmt::Display for Distro {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Distro {
    type Err = UnknownDistro;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let wanted = s.trim();
        Self::ALL
            .into_iter()
            .find(|d| d.name().eq_ignore_ascii_case(wanted))
            .ok_or_else(|| UnknownDistro {
                source: "the distribution",
                given: format!("\"{}\"", shm_cdr::text_limits::quoted(wanted)),
            })
    }
}

/// A distribution name that is none of [`Distro::ALL`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownDistro {
    source: &'static str,
    given: String,
}

impl fmt::Display for UnknownDistro {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} is {}, which has no rmw_zenoh_cpp release this crate speaks; \
             use one of humble, jazzy, kilted, lyrical, rolling",
            self.source, self.given
        )
    }
}

impl std::error::Error for UnknownDistro {}

/// A ROS 2 distribution's released rmw_zenoh_cpp and the Zenoh it is built on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct Distribution {
    /// The distribution.
    pub distro: Distro,
    /// The distribution (`"jazzy"`).
    pub name: &'static str,
    /// The rmw_zenoh_cpp release.
    pub rmw_zenoh_cpp: &'static str,
    /// The zenoh-c commit its `zenoh_cpp_vendor` builds.
    pub zenoh_c_commit: &'static str,
    /// The zenoh-c commit the vendor builds instead when the machine's cargo
    /// is older than Zenoh's minimum (1.75 to 1.87): the same Zenoh commit,
    /// built with older Rust.
    pub zenoh_c_fallback_commit: &'static str,
    /// The zenoh-cpp commit the vendor builds over zenoh-c.
    pub zenoh_cpp_commit: &'static str,
    /// The Zenoh (Rust) commit that zenoh-c commit pins.
    pub zenoh_commit: &'static str,
    /// That commit's Zenoh version: its line ([`Distribution::zenoh_line`])
    /// tells which Zenoh lines share memory with the distribution's nodes.
    pub zenoh_version: &'static str,
}

/// Every distribution with an rmw_zenoh_cpp release, in the order of
/// [`Distro::ALL`], as its `zenoh_cpp_vendor/CMakeLists.txt` says (tags
/// `release/<distro>/zenoh_cpp_vendor/<version>`): all build zenoh-c 1.8.0
/// "plus a few fixes", on Zenoh commit `2687c51`, a branch of 1.8.0 whose
/// shared memory is 1.8.0's. `tests/zenoh-lines/1.8` pins its peer to this
/// version, and `tests/zenoh-lines/check.py` proves shared memory with it
/// both ways.
pub const DISTRIBUTIONS: &[Distribution] = &[
    Distribution::on_zenoh_1_8(Distro::Humble, "0.1.9", ZENOH_CPP_1_8_0),
    Distribution::on_zenoh_1_8(Distro::Jazzy, "0.2.10", ZENOH_CPP_1_8_0),
    Distribution::on_zenoh_1_8(Distro::Kilted, "0.6.7", ZENOH_CPP_1_8_0),
    Distribution::on_zenoh_1_8(Distro::Lyrical, "0.10.5", ZENOH_CPP_LYRICAL),
    Distribution::on_zenoh_1_8(Distro::Rolling, "0.12.0", ZENOH_CPP_LYRICAL),
];

/// The zenoh-cpp commit of Humble's, Jazzy's and Kilted's vendor.
const ZENOH_CPP_1_8_0: &str = "af381b420cc8837ac7da42c9984594ef8f110e90";
/// The zenoh-cpp commit of Lyrical's and Rolling's vendor.
const ZENOH_CPP_LYRICAL: &str = "481b71bf974f684ea75afb4243b0313646d545f9";

impl Distribution {
    /// The Zenoh line of the distribution's rmw_zenoh_cpp.
    pub fn zenoh_line(&self) -> ZenohLine {
        // Every row's version is a literal of the form major.minor.patch
        // (checked by a test below).
        ZenohLine::parse(self.zenoh_version).unwrap_or(ZenohLine::new(0, 0))
    }

    /// Whether this program's Zenoh line ([`ZenohLine::BUILT`]) shares memory
    /// with the distribution's nodes (same host and user): true on 1.8 and
    /// 1.9, false on 1.10, whose shared-memory protocol differs (their
    /// messages then travel as counted copies, nothing lost).
    pub fn shares_memory_with_this_build(&self) -> bool {
        ZenohLine::BUILT
            .shares_memory_with(self.zenoh_line())
            .unwrap_or(false)
    }

    /// A release on the zenoh-c every release to date builds.
    const fn on_zenoh_1_8(
        distro: Distro,
        rmw_zenoh_cpp: &'static str,
        zenoh_cpp_commit: &'static str,
    ) -> Self {
        Self {
            distro,
            name: distro.name(),
            rmw_zenoh_cpp,
            zenoh_c_commit: "05bd370343b5161ca9269649b9a914c9c2dc4170",
            zenoh_c_fallback_commit: "b31348fa7f94f44f1f7b049c111a710e970a2725",
            zenoh_cpp_commit,
            zenoh_commit: "2687c51352121f006e3a603ce07925a8ad0b295c",
            zenoh_version: "1.8.0",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_distro_has_its_release_row() {
        for distro in Distro::ALL {
            assert_eq!(distro.release().distro, distro);
            assert_eq!(distro.name().parse::<Distro>(), Ok(distro));
            assert_eq!(distro.name().to_uppercase().parse::<Distro>(), Ok(distro));
        }
        assert_eq!(DISTRIBUTIONS.len(), Distro::ALL.len());
    }

    #[test]
    fn every_release_names_a_zenoh_line_the_runtime_knows() {
        for row in DISTRIBUTIONS {
            let line = ZenohLine::parse(row.zenoh_version);
            assert_eq!(line, Some(row.zenoh_line()), "{}", row.name);
            assert!(row.zenoh_line().shm_protocol().is_some(), "{}", row.name);
            assert_eq!(
                row.shares_memory_with_this_build(),
                ZenohLine::BUILT_SHM_PROTOCOL == 1,
                "{}",
                row.name
            );
        }
    }

    #[test]
    fn an_unknown_name_says_what_to_use() {
        let e = "iron".parse::<Distro>().unwrap_err().to_string();
        assert!(e.contains("\"iron\""), "{e}");
        assert!(e.contains("humble, jazzy, kilted, lyrical, rolling"), "{e}");
    }
}
