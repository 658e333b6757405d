//! QoS profiles as rosbag2 keeps them: `offered_qos_profiles`, a YAML list of
//! rclcpp profiles with the policies by name (bag format version 9).

use std::time::Duration;

use serde::{Deserialize, Serialize};
use shm_runtime::rmw::{Durability, History, Liveliness, Qos, Reliability};

/// rmw's infinite duration (`RMW_DURATION_INFINITE`) as rosbag2 writes it.
const INFINITE: RmwTime = RmwTime {
    sec: 9_223_372_036,
    nsec: 854_775_807,
};

/// How rosbag2 on Foxy and Galactic wrote an infinite duration (the largest
/// 32-bit seconds and nanoseconds).
const FOXY_INFINITE: RmwTime = RmwTime {
    sec: 2_147_483_647,
    nsec: 4_294_967_295,
};

/// One profile, field for field as rosbag2 writes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QosProfile {
    /// `keep_last`, `keep_all`.
    pub history: yaml_serde::Value,
    /// The depth of `keep_last`.
    pub depth: u64,
    /// `reliable`, `best_effort`.
    pub reliability: yaml_serde::Value,
    /// `volatile`, `transient_local`.
    pub durability: yaml_serde::Value,
    /// The deadline; infinite when unset.
    pub deadline: RmwTime,
    /// The lifespan; infinite when unset.
    pub lifespan: RmwTime,
    /// `automatic`, `manual_by_topic`.
    pub liveliness: yaml_serde::Value,
    /// The liveliness lease; infinite when unset.
    pub liveliness_lease_duration: RmwTime,
    /// Always `false` for ROS topics.
    pub avoid_ros_namespace_conventions: bool,
}

/// An rmw duration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct RmwTime {
    /// Seconds.
    pub sec: u64,
    /// Nanoseconds.
    pub nsec: u64,
}

impl RmwTime {
    fn of(duration: Option<Duration>) -> Self {
        duration.map_or(INFINITE, |d| Self {
            sec: d.as_secs(),
            nsec: u64::from(d.subsec_nanos()),
        })
    }

    /// `None` for infinite, and for 0 (rmw's "default", unset).
    fn duration(self) -> Option<Duration> {
        if self == INFINITE || self == FOXY_INFINITE || (self.sec == 0 && self.nsec == 0) {
            return None;
        }
        Some(Duration::from_secs(self.sec) + Duration::from_nanos(self.nsec))
    }
}

impl From<&Qos> for QosProfile {
    fn from(qos: &Qos) -> Self {
        let (history, depth) = match qos.history {
            History::KeepLast(depth) => ("keep_last", depth as u64),
            History::KeepAll => ("keep_all", 0),
        };
        let name = |s: &str| yaml_serde::Value::String(s.to_owned());
        Self {
            history: name(history),
            depth,
            reliability: name(match qos.reliability {
                Reliability::Reliable => "reliable",
                Reliability::BestEffort => "best_effort",
                Reliability::BestAvailable => "best_available",
            }),
            durability: name(match qos.durability {
                Durability::TransientLocal => "transient_local",
                Durability::Volatile => "volatile",
                Durability::BestAvailable => "best_available",
            }),
            deadline: RmwTime::of(qos.deadline),
            lifespan: RmwTime::of(qos.lifespan),
            liveliness: name(match qos.liveliness {
                Liveliness::Automatic => "automatic",
                Liveliness::ManualByTopic => "manual_by_topic",
                Liveliness::BestAvailable => "best_available",
            }),
            liveliness_lease_duration: RmwTime::of(qos.liveliness_lease),
            avoid_ros_namespace_conventions: false,
        }
    }
}

impl QosProfile {
    /// The profile as this project's QoS. Bags before format version 9 give
    /// the policies as rmw's numbers, which are read too; `system_default`
    /// and unknown policies keep ROS 2's defaults (reliable, volatile).
    pub fn to_qos(&self) -> Qos {
        let policy = |v: &yaml_serde::Value| match v {
            yaml_serde::Value::String(s) => s.clone(),
            yaml_serde::Value::Number(n) => n.to_string(),
            _ => String::new(),
        };
        let history = match policy(&self.history).as_str() {
            "keep_all" | "2" => History::KeepAll,
            _ => History::KeepLast(usize::try_from(self.depth).unwrap_or(usize::MAX).max(1)),
        };
        let reliability = match policy(&self.reliability).as_str() {
            "best_effort" | "2" => Reliability::BestEffort,
            "best_available" | "4" => Reliability::BestAvailable,
            _ => Reliability::Reliable,
        };
        let durability = match policy(&self.durability).as_str() {
            "transient_local" | "1" => Durability::TransientLocal,
            "best_available" | "4" => Durability::BestAvailable,
            _ => Durability::Volatile,
        };
        let liveliness = match policy(&self.liveliness).as_str() {
            "manual_by_topic" | "3" => Liveliness::ManualByTopic,
            "best_available" | "5" => Liveliness::BestAvailable,
            _ => Liveliness::Automatic,
        };
        let mut qos = Qos::with_history(reliability, durability, history);
        qos.deadline = self.deadline.duration();
        qos.lifespan = self.lifespan.duration();
        qos.liveliness = liveliness;
        qos.liveliness_lease = self.liveliness_lease_duration.duration();
        qos
    }
}

/// The profiles as the YAML text an MCAP channel's `offered_qos_profiles`
/// holds.
pub fn to_yaml(profiles: &[QosProfile]) -> String {
    yaml_serde::to_string(profiles).unwrap_or_default()
}

/// The profiles an MCAP channel's `offered_qos_profiles` holds.
pub fn from_yaml(text: &str) -> Result<Vec<QosProfile>, crate::Error> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    shm_cdr::text_limits::check_yaml(text)?;
    Ok(yaml_serde::from_str(text)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_read_back_to_the_same_qos() {
        for qos in [
            Qos::default(),
            Qos::sensor_data(),
            Qos::transient_local(1000).lifespan(Duration::from_secs(10)),
            Qos::with_history(
                Reliability::Reliable,
                Durability::Volatile,
                History::KeepAll,
            )
            .deadline(Duration::from_millis(1500)),
        ] {
            let text = to_yaml(&[QosProfile::from(&qos)]);
            let back = from_yaml(&text).unwrap();
            assert_eq!(back.len(), 1);
            assert_eq!(back[0].to_qos(), qos, "{text}");
        }
    }

    #[test]
    fn a_profile_reads_as_rosbag2_writes_it() {
        let text = "- history: keep_last\n  depth: 10\n  reliability: best_effort\n  durability: volatile\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: automatic\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false\n";
        let profiles = from_yaml(text).unwrap();
        assert_eq!(
            profiles[0].to_qos(),
            Qos::with_history(
                Reliability::BestEffort,
                Durability::Volatile,
                History::KeepLast(10)
            )
        );
        assert_eq!(to_yaml(&profiles), text);
    }
}
