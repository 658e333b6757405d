//! `/rosout`: the node's log as ROS 2 tools read it (`rqt_console`,
//! `ros2 topic echo /rosout`), fed by `tracing`.

use std::fmt::{self, Write as _};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use shm_cdr::msgs::builtin_interfaces::msg::Time;
use shm_cdr::msgs::rcl_interfaces::msg::Log;
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer};
use zenoh::Wait;

use crate::rmw::Qos;
use crate::ros::log_levels::effective_logger_level;
use crate::ros::node::RosNode;

/// How many log messages may wait for the publishing thread; past it they are
/// counted in [`RosoutLayer::dropped`], never waited for.
const QUEUE: usize = 1000;

/// rclcpp's `/rosout` QoS: reliable, transient local, the last 1000, a
/// lifespan of 10 s.
pub(crate) const ROSOUT_QOS: Qos =
    Qos::transient_local(1000).lifespan(std::time::Duration::from_secs(10));

/// A `tracing` layer that publishes the application's events on `/rosout` as
/// `rcl_interfaces/msg/Log`, under the node's logger name (`/demo/talker`
/// logs as `demo.talker`), with the event's level, message and fields, file,
/// module and line, on rclcpp's QoS (reliable, transient local, the last
/// 1000, a lifespan of 10 s), as rclcpp's logging does. Made by
/// [`RosNode::rosout_layer`]. It publishes what the node's logger admits: its
/// [effective level](crate::log_levels::effective_logger_level), `INFO` unless
/// `--log-level` or `~/set_logger_levels` changed it.
///
/// Events are handed to a thread of the layer's own, which publishes them:
/// logging never waits for the network, and what does not fit its queue of
/// 1000 is counted ([`dropped`](Self::dropped)). Zenoh's own events (targets
/// `zenoh…`) are not published, so publishing cannot feed itself.
///
/// ```no_run
/// use shm_runtime::RosNode;
/// use tracing_subscriber::prelude::*;
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let node = RosNode::builder(&session, "talker").namespace("/demo").wait()?;
/// tracing_subscriber::registry()
///     .with(tracing_subscriber::fmt::layer())
///     .with(node.rosout_layer()?)
///     .init();
/// tracing::info!(speed = 1.5, "moving"); // on stderr and on /rosout as demo.talker
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
pub struct RosoutLayer {
    name: String,
    sender: flume::Sender<Log>,
    dropped: Arc<AtomicU64>,
}

impl fmt::Debug for RosoutLayer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RosoutLayer")
            .field("name", &self.name)
            .field("dropped", &self.dropped())
            .finish()
    }
}

impl RosoutLayer {
    pub(crate) fn new(node: &RosNode) -> zenoh::Result<Self> {
        let publisher = node
            .declare_publisher_with_qos::<Log>("/rosout", ROSOUT_QOS)
            .wait()?;
        let (sender, receiver) = flume::bounded::<Log>(QUEUE);
        std::thread::Builder::new()
            .name("rosout".into())
            .spawn(move || {
                // Ends when the layer (every sender) is gone.
                while let Ok(log) = receiver.recv() {
                    // A failure here cannot be logged to where it failed.
                    if let Err(e) = publisher.publish(&log).wait() {
                        eprintln!("shm-runtime: /rosout: {e}");
                    }
                }
            })?;
        Ok(Self {
            name: logger_name(&node.info().namespace, &node.info().name),
            sender,
            dropped: Arc::new(AtomicU64::new(0)),
        })
    }

    /// The logger name the messages carry (`demo.talker`).
    pub fn logger_name(&self) -> &str {
        &self.name
    }

    /// Messages not published because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Publish one record that did not come through `tracing` (a logger of
    /// another language, such as Python's): `message` at `severity` (an
    /// `rcl_interfaces/msg/Log` level, `Log::INFO`, …) from the logger
    /// `name` (this node's logger or one of its children,
    /// `demo.talker.planner`), logged at `site`, if that logger's effective
    /// level admits it. Returns whether it did; what the queue had no room
    /// for is counted in [`dropped`](Self::dropped).
    pub fn log(&self, name: &str, severity: u8, message: &str, site: LogSite<'_>) -> bool {
        if !effective_logger_level(name).admits(severity) {
            return false;
        }
        let log = Log {
            stamp: now_stamp(),
            level: severity,
            name: name.to_owned(),
            msg: message.to_owned(),
            file: site.file.to_owned(),
            function: site.function.to_owned(),
            line: site.line,
        };
        if self.sender.try_send(log).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
        true
    }
}

/// Where a record was logged: the file, function and line an
/// `rcl_interfaces/msg/Log` carries.
#[derive(Debug, Clone, Copy, Default)]
pub struct LogSite<'a> {
    /// The source file.
    pub file: &'a str,
    /// The function (or module) it was logged from.
    pub function: &'a str,
    /// The line in `file`.
    pub line: u32,
}

/// The wall clock as a `/rosout` stamp.
fn now_stamp() -> Time {
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    Time {
        sec: i32::try_from(now.as_secs()).unwrap_or(i32::MAX),
        nanosec: now.subsec_nanos(),
    }
}

/// rcl's logger name of a node: its fully qualified name with `.` for `/`
/// and no leading separator (`/demo/talker` → `demo.talker`).
pub(crate) fn logger_name(namespace: &str, name: &str) -> String {
    let mut out: Vec<&str> = namespace.split('/').filter(|p| !p.is_empty()).collect();
    out.push(name);
    out.join(".")
}

/// rcl_interfaces/msg/Log's levels.
fn ros_level(level: &Level) -> u8 {
    match *level {
        Level::TRACE | Level::DEBUG => Log::DEBUG,
        Level::INFO => Log::INFO,
        Level::WARN => Log::WARN,
        Level::ERROR => Log::ERROR,
    }
}

/// The event's message, then its other fields as `name=value`, as the
/// console shows them.
#[derive(Default)]
struct Text {
    message: String,
    fields: String,
}

impl Visit for Text {
    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.message, "{value:?}");
        } else {
            let _ = write!(self.fields, " {}={value:?}", field.name());
        }
    }

    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.message.push_str(value);
        } else {
            let _ = write!(self.fields, " {}={value:?}", field.name());
        }
    }
}

impl<S: Subscriber> Layer<S> for RosoutLayer {
    fn on_event(&self, event: &Event<'_>, _ctx: Context<'_, S>) {
        let metadata = event.metadata();
        if metadata.target().starts_with("zenoh") {
            return;
        }
        let level = ros_level(metadata.level());
        if !effective_logger_level(&self.name).admits(level) {
            return;
        }
        let mut text = Text::default();
        event.record(&mut text);
        let log = Log {
            stamp: now_stamp(),
            level,
            name: self.name.clone(),
            msg: text.message + &text.fields,
            file: metadata.file().unwrap_or_default().to_owned(),
            function: metadata.module_path().unwrap_or_default().to_owned(),
            line: metadata.line().unwrap_or_default(),
        };
        if self.sender.try_send(log).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

// The node's constructor of its layer lives beside the layer: the node
// knows nothing of `/rosout`.
impl RosNode {
    /// A `tracing` layer that publishes the application's log on `/rosout`
    /// under this node's logger name, as rclcpp nodes do (see
    /// [`RosoutLayer`]); install it next to your
    /// console layer.
    pub fn rosout_layer(&self) -> zenoh::Result<RosoutLayer> {
        RosoutLayer::new(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logger_names_are_rcls() {
        assert_eq!(logger_name("/", "talker"), "talker");
        assert_eq!(logger_name("/demo", "talker"), "demo.talker");
        assert_eq!(logger_name("/a/b", "n"), "a.b.n");
    }
}
