//! The standard interfaces a ROS 2 distribution defines differently from
//! Kilted, whose definitions [`msgs`](crate::msgs) holds. Everything not
//! here is the same in every distribution with an rmw_zenoh_cpp release
//! (Humble, Jazzy, Kilted, Lyrical, Rolling): the same fields, so the same
//! bytes and, where the distribution has type hashes, the same hash.
//!
//! Compared field by field with each distribution's released interface
//! packages (`ros2-gbp/common_interfaces-release`,
//! `ros2-gbp/rcl_interfaces-release` and `ros2-gbp/rosbag2-release`, tags
//! `release/<distro>/<package>/<version>`)
//! and, in CI, with rosbags' type store of each distribution
//! (`tests/ros2/distros.py`):
//!
//! | type | Humble | Jazzy, Kilted | Lyrical, Rolling |
//! |---|---|---|---|
//! | `sensor_msgs/msg/Range` | [`humble::sensor_msgs::msg::Range`]: no `variance` | [`msgs`](crate::msgs) | [`msgs`](crate::msgs) |
//! | `lifecycle_msgs/msg/TransitionEvent` | [`msgs`](crate::msgs) | [`msgs`](crate::msgs) | [`lyrical::lifecycle_msgs::msg::TransitionEvent`]: `builtin_interfaces/Time stamp` in place of `uint64 timestamp` |
//! | `rosbag2_interfaces/msg/ReadSplitEvent`, `WriteSplitEvent` | [`humble::rosbag2_interfaces::msg`]: no `node_name` | [`msgs`](crate::msgs) | [`msgs`](crate::msgs) |
//!
//! Constants and default values changed too (e.g. `sensor_msgs/NavSatStatus`
//! gained `STATUS_UNKNOWN` and a default of -2 after Humble), but neither is
//! on the wire nor in the hash.

/// The text of the interface file of `type_name` (`pkg/msg/Name`,
/// `pkg/srv/Name`, `pkg/action/Name`) as released for `distro` (`ROS_DISTRO`'s
/// name), where it words the file differently from the text
/// [`msgs`](crate::msgs) carries (Kilted's): its comments. `None` where the
/// text is the same, or the distribution's files are not known here (Jazzy's
/// are, from its wheels; Humble, Lyrical and Rolling have none on PyPI).
///
/// ```
/// use shm_cdr::distro_msgs::source_text;
///
/// let jazzy = source_text("jazzy", "builtin_interfaces/msg/Time").unwrap();
/// assert!(jazzy.contains("{sec: -2, nanosec: 3e8}"));
/// assert_eq!(source_text("kilted", "builtin_interfaces/msg/Time"), None);
/// ```
pub fn source_text(distro: &str, type_name: &str) -> Option<&'static str> {
    crate::distro_sources::SOURCES
        .iter()
        .find(|(d, name, _)| d.eq_ignore_ascii_case(distro) && *name == type_name)
        .map(|(_, _, text)| *text)
}

/// `description` with each interface file's text as released for `distro`
/// ([`source_text`]): what a node of that distribution reports in its type
/// sources, and what its tools show.
pub fn with_sources_of(
    distro: &str,
    mut description: crate::describe::FullDescription,
) -> crate::describe::FullDescription {
    for d in std::iter::once(&mut description.own).chain(&mut description.referenced) {
        // Only a type with a file of its own (not one declared in Rust).
        if d.source.encoding.is_empty() {
            continue;
        }
        if let Some(text) = source_text(distro, d.type_name) {
            d.source.raw_file_contents = text;
        }
    }
    description
}

/// A standard message that some distributions define differently from
/// [`msgs`](crate::msgs).
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub struct Variant {
    /// The distributions that use this definition, as `ROS_DISTRO` names
    /// them.
    pub distros: &'static [&'static str],
    /// `pkg/msg/Name`.
    pub type_name: &'static str,
    /// Its RIHS01 hash.
    pub type_hash: &'static str,
    /// Its full description (for run-time types and type-description
    /// replies).
    pub describe: fn() -> crate::describe::FullDescription,
}

impl Variant {
    // Unused when no interface package it serves is turned on.
    #[allow(dead_code)]
    fn of<M: crate::RosMessage>(distros: &'static [&'static str]) -> Self {
        Self {
            distros,
            type_name: M::TYPE_NAME,
            type_hash: M::type_hash(),
            describe: M::full_description,
        }
    }
}

/// Every standard message some distribution defines differently, with the
/// features of this crate it needs turned on.
///
/// ```
/// let humble: Vec<&str> = shm_cdr::distro_msgs::variants()
///     .iter()
///     .filter(|v| v.distros.contains(&"humble"))
///     .map(|v| v.type_name)
///     .collect();
/// // With the default features; `rosbag2_interfaces` adds Humble's
/// // `ReadSplitEvent` and `WriteSplitEvent`.
/// assert!(humble.contains(&"sensor_msgs/msg/Range"));
/// ```
// Each push is behind features of its own: a `vec![]` cannot say that.
#[allow(clippy::vec_init_then_push)]
pub fn variants() -> Vec<Variant> {
    #[allow(unused_mut)]
    let mut out = Vec::new();
    #[cfg(feature = "sensor_msgs")]
    out.push(Variant::of::<humble::sensor_msgs::msg::Range>(&["humble"]));
    #[cfg(feature = "rosbag2_interfaces")]
    out.push(Variant::of::<humble::rosbag2_interfaces::msg::ReadSplitEvent>(&["humble"]));
    #[cfg(feature = "rosbag2_interfaces")]
    out.push(Variant::of::<
        humble::rosbag2_interfaces::msg::WriteSplitEvent,
    >(&["humble"]));
    #[cfg(all(feature = "lifecycle_msgs", feature = "builtin_interfaces"))]
    out.push(Variant::of::<lyrical::lifecycle_msgs::msg::TransitionEvent>(&["lyrical", "rolling"]));
    out
}

/// Humble's definitions where they differ.
pub mod humble {
    /// `sensor_msgs` as Humble defines it.
    #[cfg(feature = "sensor_msgs")]
    pub mod sensor_msgs {
        /// Messages.
        pub mod msg {
            use crate::msgs::std_msgs::msg::Header;

            /// `sensor_msgs/msg/Range` as Humble defines it: one range
            /// reading of an active ranger, without the `variance` later
            /// distributions added.
            ///
            /// ```
            /// use shm_cdr::distro_msgs::humble::sensor_msgs::msg::Range;
            /// use shm_cdr::{encoded_size, RosMessage};
            ///
            /// assert_eq!(Range::TYPE_NAME, "sensor_msgs/msg/Range");
            /// // Four bytes shorter than Kilted's: no `variance`.
            /// let kilted = shm_cdr::msgs::sensor_msgs::msg::Range::default();
            /// assert_eq!(encoded_size(&Range::default()) + 4, encoded_size(&kilted));
            /// ```
            #[derive(crate::RosMessage, Debug, Clone, Default, PartialEq)]
            #[ros(
                type_name = "sensor_msgs/msg/Range",
                crate = "crate",
                source = "std_msgs/Header header\nuint8 ULTRASOUND=0\nuint8 INFRARED=1\nuint8 radiation_type\nfloat32 field_of_view\nfloat32 min_range\nfloat32 max_range\nfloat32 range\n"
            )]
            pub struct Range {
                /// When and in which frame the reading was taken.
                pub header: Header,
                /// [`Range::ULTRASOUND`] or [`Range::INFRARED`].
                pub radiation_type: u8,
                /// The arc the reading is valid for, in radians.
                pub field_of_view: f32,
                /// The shortest range the sensor reports, in metres.
                pub min_range: f32,
                /// The longest range the sensor reports, in metres.
                pub max_range: f32,
                /// The range measured, in metres (REP 117: -Inf and +Inf for
                /// detections too close and none within a fixed range).
                pub range: f32,
            }

            impl Range {
                /// An ultrasound ranger.
                pub const ULTRASOUND: u8 = 0;
                /// An infrared ranger.
                pub const INFRARED: u8 = 1;
            }
        }
    }

    /// `rosbag2_interfaces` as Humble defines it: its split events name no
    /// node.
    #[cfg(feature = "rosbag2_interfaces")]
    pub mod rosbag2_interfaces {
        /// Messages.
        pub mod msg {
            /// `rosbag2_interfaces/msg/ReadSplitEvent` as Humble defines it:
            /// without the `node_name` later distributions added.
            ///
            /// ```
            /// use shm_cdr::distro_msgs::humble::rosbag2_interfaces::msg::ReadSplitEvent;
            /// use shm_cdr::RosMessage;
            ///
            /// let jazzy = shm_cdr::msgs::rosbag2_interfaces::msg::ReadSplitEvent::type_hash();
            /// assert_ne!(ReadSplitEvent::type_hash(), jazzy);
            /// ```
            #[derive(crate::RosMessage, Debug, Clone, Default, PartialEq, Eq, Hash)]
            #[ros(
                type_name = "rosbag2_interfaces/msg/ReadSplitEvent",
                crate = "crate",
                source = "# A playback moved on to the next file of its recording.\n\n# The full path of the file finished\nstring closed_file\n\n# The full path of the file the playback continues in\nstring opened_file\n"
            )]
            pub struct ReadSplitEvent {
                /// The full path of the file finished.
                pub closed_file: String,
                /// The full path of the file the playback continues in.
                pub opened_file: String,
            }

            /// `rosbag2_interfaces/msg/WriteSplitEvent` as Humble defines it:
            /// without the `node_name` later distributions added.
            #[derive(crate::RosMessage, Debug, Clone, Default, PartialEq, Eq, Hash)]
            #[ros(
                type_name = "rosbag2_interfaces/msg/WriteSplitEvent",
                crate = "crate",
                source = "# A recording moved on to a new file.\n\n# The full path of the file closed\nstring closed_file\n\n# The full path of the file opened in its place\nstring opened_file\n"
            )]
            pub struct WriteSplitEvent {
                /// The full path of the file closed.
                pub closed_file: String,
                /// The full path of the file opened in its place.
                pub opened_file: String,
            }
        }
    }
}

/// Lyrical's definitions where they differ; Rolling's are the same.
pub mod lyrical {
    /// `lifecycle_msgs` as Lyrical and Rolling define it.
    #[cfg(all(feature = "lifecycle_msgs", feature = "builtin_interfaces"))]
    pub mod lifecycle_msgs {
        /// Messages.
        pub mod msg {
            use crate::msgs::builtin_interfaces::msg::Time;
            use crate::msgs::lifecycle_msgs::msg::{State, Transition};

            /// `lifecycle_msgs/msg/TransitionEvent` as Lyrical and Rolling
            /// define it: the time of the transition as a
            /// `builtin_interfaces/Time`.
            ///
            /// ```
            /// use shm_cdr::distro_msgs::lyrical::lifecycle_msgs::msg::TransitionEvent;
            /// use shm_cdr::RosMessage;
            ///
            /// let kilted = shm_cdr::msgs::lifecycle_msgs::msg::TransitionEvent::type_hash();
            /// assert_ne!(TransitionEvent::type_hash(), kilted);
            /// ```
            #[derive(crate::RosMessage, Debug, Clone, Default, PartialEq, Eq, Hash)]
            #[ros(
                type_name = "lifecycle_msgs/msg/TransitionEvent",
                crate = "crate",
                source = "builtin_interfaces/Time stamp\nTransition transition\nState start_state\nState goal_state\n"
            )]
            pub struct TransitionEvent {
                /// When the transition happened.
                pub stamp: Time,
                /// The transition's id and label.
                pub transition: Transition,
                /// The state it left.
                pub start_state: State,
                /// The state it went to.
                pub goal_state: State,
            }
        }
    }
}

#[cfg(all(test, feature = "sensor_msgs", feature = "rosbag2_interfaces"))]
mod tests {
    /// Humble defines these three differently from the generated types.
    #[test]
    fn humble_variants_with_their_features_on() {
        let humble: Vec<&str> = super::variants()
            .iter()
            .filter(|v| v.distros.contains(&"humble"))
            .map(|v| v.type_name)
            .collect();
        assert_eq!(
            humble,
            [
                "sensor_msgs/msg/Range",
                "rosbag2_interfaces/msg/ReadSplitEvent",
                "rosbag2_interfaces/msg/WriteSplitEvent",
            ]
        );
    }
}
