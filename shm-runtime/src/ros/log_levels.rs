//! Logger levels as rcutils keeps them: one table per process, a level per
//! logger name (`demo.talker`, `demo.talker.planner`), a default for names
//! with none, and a logger's effective level found by walking up its dotted
//! name. `/rosout` ([`RosoutLayer`](crate::RosoutLayer)) publishes what its
//! node's logger admits; `--ros-args --log-level` and a node's
//! `~/set_logger_levels` service ([`RosNodeBuilder::logger_service`]) change
//! the table, as they do in rclcpp and rclpy.
//!
//! ```
//! use shm_runtime::log_levels::{self, LogLevel};
//!
//! log_levels::set_logger_level("demo.talker", LogLevel::Debug)?;
//! assert_eq!(log_levels::effective_logger_level("demo.talker.planner"), LogLevel::Debug);
//! assert_eq!(log_levels::logger_level("demo.talker.planner"), LogLevel::Unset);
//! # Ok::<(), log_levels::LoggerLevelError>(())
//! ```
//!
//! [`RosNodeBuilder::logger_service`]: crate::RosNodeBuilder::logger_service

use std::collections::HashMap;
use std::fmt;
use std::sync::{Mutex, MutexGuard, OnceLock};

use shm_cdr::msgs::rcl_interfaces::msg::{LoggerLevel, SetLoggerLevelsResult};
use shm_cdr::msgs::rcl_interfaces::srv::{
    GetLoggerLevels_Request, GetLoggerLevels_Response, SetLoggerLevels_Request,
    SetLoggerLevels_Response,
};

/// A logger's severity threshold, numbered as rcutils numbers it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum LogLevel {
    /// No level of its own: the logger takes its parent's (or the default).
    Unset = 0,
    /// Everything.
    Debug = 10,
    /// Info and above (the default logger's level at startup).
    Info = 20,
    /// Warnings and above.
    Warn = 30,
    /// Errors and above.
    Error = 40,
    /// Fatal only.
    Fatal = 50,
}

impl LogLevel {
    /// The level numbered `n` (0, 10, 20, 30, 40 or 50).
    pub fn from_number(n: u32) -> Option<Self> {
        Some(match n {
            0 => Self::Unset,
            10 => Self::Debug,
            20 => Self::Info,
            30 => Self::Warn,
            40 => Self::Error,
            50 => Self::Fatal,
            _ => return None,
        })
    }

    /// The level named `text`, in any case: `unset`, `debug`, `info`, `warn`,
    /// `error`, `fatal` (rcutils' names).
    pub fn parse(text: &str) -> Option<Self> {
        Some(match text.to_ascii_lowercase().as_str() {
            "unset" => Self::Unset,
            "debug" => Self::Debug,
            "info" => Self::Info,
            "warn" => Self::Warn,
            "error" => Self::Error,
            "fatal" => Self::Fatal,
            _ => return None,
        })
    }

    /// Whether a message of severity `severity` (an `rcl_interfaces/msg/Log`
    /// level) passes this threshold.
    pub fn admits(self, severity: u8) -> bool {
        severity >= self as u8
    }
}

impl fmt::Display for LogLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Unset => "UNSET",
            Self::Debug => "DEBUG",
            Self::Info => "INFO",
            Self::Warn => "WARN",
            Self::Error => "ERROR",
            Self::Fatal => "FATAL",
        })
    }
}

struct Table {
    default: LogLevel,
    levels: HashMap<String, LogLevel>,
}

fn table() -> MutexGuard<'static, Table> {
    static TABLE: OnceLock<Mutex<Table>> = OnceLock::new();
    TABLE
        .get_or_init(|| {
            Mutex::new(Table {
                default: LogLevel::Info,
                levels: HashMap::new(),
            })
        })
        .lock()
        // The table is whole between statements.
        .unwrap_or_else(|e| e.into_inner())
}

/// The most loggers the table keeps a level for: `~/set_logger_levels`
/// may be called by any node, and each name it gives is kept.
pub const MAX_LOGGERS: usize = 4096;

/// The longest logger name the table keeps, in bytes.
pub const MAX_LOGGER_NAME_LEN: usize = 1024;

/// Why a logger's level was not set.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoggerLevelError(String);

impl fmt::Display for LoggerLevelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for LoggerLevelError {}

/// Set the level of logger `name`; the empty name sets the default level.
/// [`LogLevel::Unset`] forgets the logger's level, so the table holds only
/// loggers with one; it holds at most [`MAX_LOGGERS`] names of at most
/// [`MAX_LOGGER_NAME_LEN`] bytes, and refuses more.
pub fn set_logger_level(name: &str, level: LogLevel) -> Result<(), LoggerLevelError> {
    let mut table = table();
    if name.is_empty() {
        table.default = level;
        return Ok(());
    }
    if level == LogLevel::Unset {
        table.levels.remove(name);
        // A table emptied of many names gives their memory back.
        if table.levels.capacity() > 4 * table.levels.len().max(64) {
            table.levels.shrink_to_fit();
        }
        return Ok(());
    }
    if name.len() > MAX_LOGGER_NAME_LEN {
        return Err(LoggerLevelError(format!(
            "a logger name of {} bytes: at most {MAX_LOGGER_NAME_LEN} are kept",
            name.len()
        )));
    }
    if table.levels.len() >= MAX_LOGGERS && !table.levels.contains_key(name) {
        return Err(LoggerLevelError(format!(
            "levels are kept for {MAX_LOGGERS} loggers at most: unset some first"
        )));
    }
    table.levels.insert(name.to_owned(), level);
    Ok(())
}

/// The level set for logger `name` (`Unset` if none was); the empty name
/// gives the default level.
pub fn logger_level(name: &str) -> LogLevel {
    let table = table();
    if name.is_empty() {
        table.default
    } else {
        table.levels.get(name).copied().unwrap_or(LogLevel::Unset)
    }
}

/// The level that applies to logger `name`: its own, else its nearest
/// ancestor's (`a.b` for `a.b.c`), else the default.
pub fn effective_logger_level(name: &str) -> LogLevel {
    let table = table();
    let mut current = name;
    while !current.is_empty() {
        match table.levels.get(current) {
            Some(&level) if level != LogLevel::Unset => return level,
            _ => {}
        }
        current = current.rsplit_once('.').map_or("", |(parent, _)| parent);
    }
    table.default
}

/// `--log-level` arguments among a command line's ROS arguments, as rcl reads
/// them: `--log-level debug` (the default level) or `--log-level
/// name:=debug` (one logger).
pub(crate) fn from_ros_args(args: &[String]) -> Result<Vec<(String, LogLevel)>, String> {
    let mut out = Vec::new();
    let mut in_ros_args = false;
    let mut args = args.iter();
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--ros-args" => in_ros_args = true,
            "--" => in_ros_args = false,
            "--log-level" if in_ros_args => {
                let value = args
                    .next()
                    .ok_or("--log-level: a level must follow (debug, info, warn, error, fatal)")?;
                let (name, level) = value.split_once(":=").unwrap_or(("", value));
                let level = LogLevel::parse(level).ok_or_else(|| {
                    format!(
                        "--log-level {value}: `{level}` is not a level: write debug, info, warn, error, fatal or unset"
                    )
                })?;
                out.push((name.to_owned(), level));
            }
            _ => {}
        }
    }
    Ok(out)
}

/// `~/get_logger_levels`, as rclcpp and rclpy answer it.
pub(crate) fn get_levels(request: &GetLoggerLevels_Request) -> GetLoggerLevels_Response {
    GetLoggerLevels_Response {
        levels: request
            .names
            .iter()
            .map(|name| LoggerLevel {
                name: name.clone(),
                level: u32::from(logger_level(name) as u8),
            })
            .collect(),
    }
}

/// `~/set_logger_levels`, as rclcpp and rclpy answer it.
pub(crate) fn set_levels(request: &SetLoggerLevels_Request) -> SetLoggerLevels_Response {
    SetLoggerLevels_Response {
        results: request
            .levels
            .iter()
            .map(|wanted| match LogLevel::from_number(wanted.level) {
                Some(level) => match set_logger_level(&wanted.name, level) {
                    Ok(()) => SetLoggerLevelsResult {
                        successful: true,
                        reason: String::new(),
                    },
                    Err(e) => SetLoggerLevelsResult {
                        successful: false,
                        reason: format!("Failed reason: {e}."),
                    },
                },
                None => SetLoggerLevelsResult {
                    successful: false,
                    reason: "Failed reason: Invalid logger level.".into(),
                },
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // The table is process-wide: each test uses names of its own.

    #[test]
    fn a_logger_takes_its_nearest_ancestors_level() {
        set_logger_level("t1.robot", LogLevel::Warn).unwrap();
        set_logger_level("t1.robot.arm.joint", LogLevel::Unset).unwrap();
        assert_eq!(effective_logger_level("t1.robot.arm.joint"), LogLevel::Warn);
        assert_eq!(logger_level("t1.robot.arm"), LogLevel::Unset);
        assert_eq!(effective_logger_level("t1.robotic"), logger_level(""));
        assert!(LogLevel::Warn.admits(40) && !LogLevel::Warn.admits(20));
    }

    #[test]
    fn the_service_refuses_levels_rcutils_does_not_know() {
        let reply = set_levels(&SetLoggerLevels_Request {
            levels: vec![
                LoggerLevel {
                    name: "t2.a".into(),
                    level: 15,
                },
                LoggerLevel {
                    name: "t2.b".into(),
                    level: 40,
                },
            ],
        });
        assert!(!reply.results[0].successful);
        assert!(reply.results[1].successful);
        let levels = get_levels(&GetLoggerLevels_Request {
            names: vec!["t2.a".into(), "t2.b".into()],
        });
        let numbers: Vec<u32> = levels.levels.iter().map(|l| l.level).collect();
        assert_eq!(numbers, [0, 40]);
    }

    #[test]
    fn the_table_keeps_only_loggers_with_a_level_and_at_most_so_many() {
        let request = |names: std::ops::Range<usize>, level: u32| SetLoggerLevels_Request {
            levels: names
                .map(|i| LoggerLevel {
                    name: format!("t3.n{i}"),
                    level,
                })
                .collect(),
        };
        let held = || table().levels.len();
        let before = held();
        // Unset names are forgotten, not kept at level 0.
        let reply = set_levels(&request(0..10_000, 0));
        assert!(reply.results.iter().all(|r| r.successful));
        assert_eq!(held(), before);
        // Past the cap, each further name is refused with the reason.
        let reply = set_levels(&request(0..MAX_LOGGERS + 10, 10));
        let refused: Vec<_> = reply.results.iter().filter(|r| !r.successful).collect();
        assert!(refused.len() >= 10, "{} refused", refused.len());
        assert!(
            refused[0].reason.contains("4096 loggers"),
            "{}",
            refused[0].reason
        );
        assert!(held() <= MAX_LOGGERS);
        // Unset again: the room is free once more.
        set_levels(&request(0..MAX_LOGGERS + 10, 0));
        assert!(held() <= before);
        let long = "x".repeat(MAX_LOGGER_NAME_LEN + 1);
        assert!(set_logger_level(&long, LogLevel::Debug).is_err());
    }

    #[test]
    fn log_level_arguments_read_as_rcl_reads_them() {
        let args: Vec<String> = [
            "prog",
            "--log-level",
            "debug",
            "--ros-args",
            "--log-level",
            "WARN",
            "--log-level",
            "demo.talker:=debug",
            "--",
            "--log-level",
            "x",
        ]
        .map(String::from)
        .to_vec();
        assert_eq!(
            from_ros_args(&args).unwrap(),
            [
                (String::new(), LogLevel::Warn),
                ("demo.talker".to_owned(), LogLevel::Debug)
            ]
        );
        let bad: Vec<String> = ["--ros-args", "--log-level", "loud"]
            .map(String::from)
            .to_vec();
        assert!(from_ros_args(&bad)
            .unwrap_err()
            .contains("`loud` is not a level"));
    }
}
