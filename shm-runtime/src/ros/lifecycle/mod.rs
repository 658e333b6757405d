//! Managed (lifecycle) nodes, as rclcpp's and rclpy's: the standard state
//! machine (unconfigured, inactive, active, finalized and the transition
//! states between them), your callbacks for each transition, the five
//! `lifecycle_msgs` services a lifecycle manager drives (`~/change_state`,
//! `~/get_state`, `~/get_available_states`, `~/get_available_transitions`,
//! `~/get_transition_graph`), `~/transition_event`, and publishers that
//! publish only while the node is active.
//!
//! ```no_run
//! use shm_cdr::msgs::std_msgs::String as Text;
//! use shm_runtime::lifecycle::{CallbackReturn, Managed, State};
//! use shm_runtime::RosNode;
//! use zenoh::Wait;
//!
//! struct Camera {
//!     device: Option<String>,
//! }
//!
//! impl Managed for Camera {
//!     fn on_configure(&mut self, _previous: State) -> CallbackReturn {
//!         self.device = Some("/dev/video0".into());
//!         CallbackReturn::Success
//!     }
//!     fn on_cleanup(&mut self, _previous: State) -> CallbackReturn {
//!         self.device = None;
//!         CallbackReturn::Success
//!     }
//! }
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
//! let session = zenoh::open(zenoh::Config::default()).wait()?;
//! let node = RosNode::builder(&session, "camera").wait()?;
//! let lifecycle = node.lifecycle(Camera { device: None })?;
//! let status = lifecycle.publisher(node.declare_publisher::<Text>("status").wait()?);
//!
//! // A lifecycle manager (Nav2's, `ros2 lifecycle set`) drives the node
//! // through its services; the node can drive itself too.
//! lifecycle.configure()?;
//! lifecycle.activate()?;
//! assert_eq!(lifecycle.state(), State::Active);
//! status.publish(&Text { data: "streaming".into() }).wait()?;
//! # Ok(())
//! # }
//! ```

mod machine;

use std::any::Any;
use std::fmt;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use shm_cdr::distro_msgs::lyrical::lifecycle_msgs::msg::TransitionEvent as StampedTransitionEvent;
use shm_cdr::msgs::lifecycle_msgs::msg::TransitionEvent;
use shm_cdr::msgs::lifecycle_msgs::srv::{
    ChangeState, ChangeState_Response, GetAvailableStates, GetAvailableStates_Response,
    GetAvailableTransitions, GetAvailableTransitions_Response, GetState, GetState_Response,
};
use shm_cdr::RosMessage;
use zenoh::{Resolvable, Wait};

pub use machine::State;
use machine::Step;

use crate::{PublishError, PublishOutcome, RosNode, RosPublisher};

/// What a transition callback says of its work.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CallbackReturn {
    /// Done: the node moves on to the transition's goal.
    Success,
    /// Not done, nothing broken: the node goes back to where it was.
    Failure,
    /// Something broke: the node goes to `ErrorProcessing` and
    /// [`Managed::on_error`] decides between `Unconfigured` (success) and
    /// `Finalized`.
    Error,
}

/// Your side of a managed node: one callback per transition, each given
/// the primary state the transition started from. Every callback defaults
/// to [`CallbackReturn::Success`]; a callback that panics counts as
/// [`CallbackReturn::Error`] (as an exception does in rclpy).
pub trait Managed: Send + 'static {
    /// `Unconfigured` → `Inactive`: load settings, allocate.
    fn on_configure(&mut self, previous: State) -> CallbackReturn {
        let _ = previous;
        CallbackReturn::Success
    }
    /// `Inactive` → `Active`: start processing. Lifecycle publishers
    /// publish from when this returns success.
    fn on_activate(&mut self, previous: State) -> CallbackReturn {
        let _ = previous;
        CallbackReturn::Success
    }
    /// `Active` → `Inactive`: stop processing.
    fn on_deactivate(&mut self, previous: State) -> CallbackReturn {
        let _ = previous;
        CallbackReturn::Success
    }
    /// `Inactive` → `Unconfigured`: release what `on_configure` took.
    fn on_cleanup(&mut self, previous: State) -> CallbackReturn {
        let _ = previous;
        CallbackReturn::Success
    }
    /// Any primary state but `Finalized` → `Finalized`.
    fn on_shutdown(&mut self, previous: State) -> CallbackReturn {
        let _ = previous;
        CallbackReturn::Success
    }
    /// After a callback returned [`CallbackReturn::Error`]: success leads
    /// to `Unconfigured`, anything else to `Finalized`. `previous` is the
    /// state the failed transition started from.
    fn on_error(&mut self, previous: State) -> CallbackReturn {
        let _ = previous;
        CallbackReturn::Success
    }
}

/// A transition a node (or its manager) asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Transition {
    /// `Unconfigured` → `Inactive`.
    Configure,
    /// `Inactive` → `Unconfigured`.
    Cleanup,
    /// `Inactive` → `Active`.
    Activate,
    /// `Active` → `Inactive`.
    Deactivate,
    /// `Unconfigured`, `Inactive` or `Active` → `Finalized`.
    Shutdown,
}

impl Transition {
    /// rcl's label of the transition.
    pub const fn label(self) -> &'static str {
        match self {
            Transition::Configure => "configure",
            Transition::Cleanup => "cleanup",
            Transition::Activate => "activate",
            Transition::Deactivate => "deactivate",
            Transition::Shutdown => "shutdown",
        }
    }
}

/// Why a lifecycle call failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum LifecycleError {
    /// The transition does not leave the node's current state (e.g.
    /// `activate` while `Unconfigured`).
    NotAvailable {
        /// The transition asked for (its label, or its id).
        transition: String,
        /// Where the node is.
        state: State,
    },
    /// The services or the event publisher could not be declared.
    Zenoh(zenoh::Error),
}

impl fmt::Display for LifecycleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotAvailable { transition, state } => {
                let offered: Vec<_> = machine::from(*state).map(|s| s.label).collect();
                write!(
                    f,
                    "lifecycle: no transition {transition} from state {state} (it offers: {})",
                    if offered.is_empty() {
                        "none".to_owned()
                    } else {
                        offered.join(", ")
                    }
                )
            }
            Self::Zenoh(e) => write!(f, "lifecycle: {e}"),
        }
    }
}

impl std::error::Error for LifecycleError {}

impl From<zenoh::Error> for LifecycleError {
    fn from(e: zenoh::Error) -> Self {
        Self::Zenoh(e)
    }
}

/// The state machine and what it drives.
struct Core {
    machine: Mutex<Box<dyn Managed>>,
    /// The current state's id, readable without waiting for a transition.
    state: Arc<AtomicU8>,
    events: TransitionEvents,
}

/// `~/transition_event` in the distribution's definition of
/// `lifecycle_msgs/msg/TransitionEvent`.
enum TransitionEvents {
    /// `uint64 timestamp`: Humble to Kilted.
    Timestamp(RosPublisher<TransitionEvent>),
    /// `builtin_interfaces/Time stamp`: Lyrical and Rolling.
    Stamp(RosPublisher<StampedTransitionEvent>),
}

impl TransitionEvents {
    fn declare(node: &RosNode) -> zenoh::Result<Self> {
        const TOPIC: &str = "~/transition_event";
        Ok(if node.info().distro.has_stamped_transition_events() {
            Self::Stamp(node.declare_publisher(TOPIC).wait()?)
        } else {
            Self::Timestamp(node.declare_publisher(TOPIC).wait()?)
        })
    }

    /// Announce a step, as rcl does: only the start and goal states are
    /// filled in.
    fn publish(&self, start: State, goal: State) -> Result<(), crate::PublishError> {
        match self {
            Self::Timestamp(events) => events
                .publish(&TransitionEvent {
                    start_state: start.to_msg(),
                    goal_state: goal.to_msg(),
                    ..Default::default()
                })
                .wait()
                .map(drop),
            Self::Stamp(events) => events
                .publish(&StampedTransitionEvent {
                    start_state: start.to_msg(),
                    goal_state: goal.to_msg(),
                    ..Default::default()
                })
                .wait()
                .map(drop),
        }
    }
}

impl Core {
    fn managed(&self) -> MutexGuard<'_, Box<dyn Managed>> {
        // A callback that panicked is caught inside the lock; the state is
        // kept apart, in `state`.
        self.machine.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn current(&self) -> State {
        state_of(self.state.load(Ordering::Acquire))
    }

    /// Take `step`, announcing it on `~/transition_event`.
    fn take(&self, step: Step) {
        self.state.store(step.goal.id(), Ordering::Release);
        if let Err(e) = self.events.publish(step.start, step.goal) {
            tracing::warn!("lifecycle: could not publish the transition event: {e}");
        }
    }

    /// Run the transition `asked` for from the current state, as rcl does:
    /// into its transition state, the callback, out by the callback's
    /// result (and through `on_error` after an error).
    fn change(&self, asked: Asked<'_>) -> Result<CallbackReturn, LifecycleError> {
        let mut managed = self.managed();
        let start = self.current();
        let step = match asked {
            Asked::Id(id) => machine::by_id(start, id),
            Asked::Label(label) => machine::by_label(start, label),
        };
        let step = step.ok_or_else(|| LifecycleError::NotAvailable {
            transition: asked.to_string(),
            state: start,
        })?;
        self.take(step);
        let result = run(&mut **managed, step.goal, start);
        self.finish(step.goal, result);
        if result == CallbackReturn::Error {
            let recovered = run(&mut **managed, State::ErrorProcessing, start);
            self.finish(State::ErrorProcessing, recovered);
        }
        Ok(result)
    }

    /// Leave transition state `from` by `result`'s transition.
    fn finish(&self, from: State, result: CallbackReturn) {
        match machine::by_label(from, machine::result_label(result)) {
            Some(step) => self.take(step),
            // Every transition state has all three (a test holds the table to it).
            None => tracing::error!("lifecycle: no {result:?} transition out of {from}"),
        }
    }
}

/// A transition as asked for: by id, or by label (which rcl looks up among
/// the transitions leaving the current state).
#[derive(Debug, Clone, Copy)]
enum Asked<'a> {
    Id(u8),
    Label(&'a str),
}

impl fmt::Display for Asked<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Asked::Id(id) => write!(f, "with id {id}"),
            Asked::Label(label) => write!(f, "{label:?}"),
        }
    }
}

/// Call the callback of transition state `state`; a panic is an error.
fn run(managed: &mut dyn Managed, state: State, previous: State) -> CallbackReturn {
    let call = AssertUnwindSafe(|| match state {
        State::Configuring => managed.on_configure(previous),
        State::Activating => managed.on_activate(previous),
        State::Deactivating => managed.on_deactivate(previous),
        State::CleaningUp => managed.on_cleanup(previous),
        State::ShuttingDown => managed.on_shutdown(previous),
        State::ErrorProcessing => managed.on_error(previous),
        _ => CallbackReturn::Success,
    });
    catch_unwind(call).unwrap_or_else(|_| {
        tracing::error!("lifecycle: the {state} callback panicked; taken as an error");
        CallbackReturn::Error
    })
}

fn state_of(id: u8) -> State {
    State::ALL
        .into_iter()
        .find(|s| s.id() == id)
        .unwrap_or(State::Unknown)
}

/// A managed node's state machine, served to lifecycle managers while this
/// handle lives (see the [module](self) docs). Created `Unconfigured` by
/// [`RosNode::lifecycle`].
pub struct Lifecycle {
    core: Arc<Core>,
    _services: Vec<Box<dyn Any + Send + Sync>>,
}

impl fmt::Debug for Lifecycle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Lifecycle")
            .field("state", &self.state())
            .finish_non_exhaustive()
    }
}

impl RosNode {
    /// Make this a managed (lifecycle) node driven by `managed`'s callbacks:
    /// it starts `Unconfigured`, and serves `~/change_state`, `~/get_state`,
    /// `~/get_available_states`, `~/get_available_transitions` and
    /// `~/get_transition_graph`, answering as rclpy's lifecycle node
    /// answers, and announces each step on `~/transition_event`.
    pub fn lifecycle(&self, managed: impl Managed) -> zenoh::Result<Lifecycle> {
        let events = TransitionEvents::declare(self)?;
        let core = Arc::new(Core {
            machine: Mutex::new(Box::new(managed)),
            state: Arc::new(AtomicU8::new(State::Unconfigured.id())),
            events,
        });
        let mut services: Vec<Box<dyn Any + Send + Sync>> = Vec::new();
        let c = core.clone();
        services.push(Box::new(
            self.declare_service::<ChangeState>("~/change_state")
                .handler(move |request| {
                    let transition = &request.transition;
                    // A label wins over the id.
                    let asked = match transition.label.as_str() {
                        "" => Asked::Id(transition.id),
                        label => Asked::Label(label),
                    };
                    let result = c.change(asked);
                    if let Err(e) = &result {
                        tracing::warn!("{e}");
                    }
                    ChangeState_Response {
                        success: matches!(result, Ok(CallbackReturn::Success)),
                    }
                })
                .wait()?,
        ));
        let c = core.clone();
        services.push(Box::new(
            self.declare_service::<GetState>("~/get_state")
                .handler(move |_| GetState_Response {
                    current_state: c.current().to_msg(),
                })
                .wait()?,
        ));
        services.push(Box::new(
            self.declare_service::<GetAvailableStates>("~/get_available_states")
                .handler(|_| GetAvailableStates_Response {
                    available_states: State::ALL.map(State::to_msg).to_vec(),
                })
                .wait()?,
        ));
        let c = core.clone();
        services.push(Box::new(
            self.declare_service::<GetAvailableTransitions>("~/get_available_transitions")
                .handler(move |_| GetAvailableTransitions_Response {
                    available_transitions: machine::from(c.current()).map(Step::to_msg).collect(),
                })
                .wait()?,
        ));
        services.push(Box::new(
            self.declare_service::<GetAvailableTransitions>("~/get_transition_graph")
                .handler(|_| GetAvailableTransitions_Response {
                    available_transitions: machine::STEPS.map(Step::to_msg).to_vec(),
                })
                .wait()?,
        ));
        Ok(Lifecycle {
            core,
            _services: services,
        })
    }
}

impl Lifecycle {
    /// The current state.
    pub fn state(&self) -> State {
        self.core.current()
    }

    /// Take `transition` from the current state, running its callback (and
    /// `on_error` after an error); what the callback returned. Waits for a
    /// transition under way (from a manager's request) to end first.
    pub fn trigger(&self, transition: Transition) -> Result<CallbackReturn, LifecycleError> {
        self.core.change(Asked::Label(transition.label()))
    }

    /// [`trigger`](Self::trigger)`(Transition::Configure)`.
    pub fn configure(&self) -> Result<CallbackReturn, LifecycleError> {
        self.trigger(Transition::Configure)
    }

    /// [`trigger`](Self::trigger)`(Transition::Activate)`.
    pub fn activate(&self) -> Result<CallbackReturn, LifecycleError> {
        self.trigger(Transition::Activate)
    }

    /// [`trigger`](Self::trigger)`(Transition::Deactivate)`.
    pub fn deactivate(&self) -> Result<CallbackReturn, LifecycleError> {
        self.trigger(Transition::Deactivate)
    }

    /// [`trigger`](Self::trigger)`(Transition::Cleanup)`.
    pub fn cleanup(&self) -> Result<CallbackReturn, LifecycleError> {
        self.trigger(Transition::Cleanup)
    }

    /// [`trigger`](Self::trigger)`(Transition::Shutdown)`, from whichever
    /// primary state the node is in.
    pub fn shutdown(&self) -> Result<CallbackReturn, LifecycleError> {
        self.trigger(Transition::Shutdown)
    }

    /// Make `publisher` a lifecycle publisher of this node: it publishes only
    /// while the node is `Active`.
    pub fn publisher<T: RosMessage>(&self, publisher: RosPublisher<T>) -> LifecyclePublisher<T> {
        LifecyclePublisher {
            publisher,
            state: self.core.state.clone(),
            warned: AtomicBool::new(false),
        }
    }
}

/// A publisher that publishes only while its node is `Active` (see
/// [`Lifecycle::publisher`]); otherwise a publish sends nothing, resolves to
/// `Ok(None)` and warns once per inactive spell, as rclcpp's does.
pub struct LifecyclePublisher<T> {
    publisher: RosPublisher<T>,
    state: Arc<AtomicU8>,
    /// Whether the current inactive spell was warned about.
    warned: AtomicBool,
}

impl<T> fmt::Debug for LifecyclePublisher<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LifecyclePublisher")
            .field("publisher", &self.publisher)
            .field("active", &self.is_active())
            .finish()
    }
}

impl<T> LifecyclePublisher<T> {
    /// Whether it publishes now (its node is `Active`).
    pub fn is_active(&self) -> bool {
        self.state.load(Ordering::Acquire) == State::Active.id()
    }

    /// The publisher underneath, for its key expression, matching and pool.
    pub fn publisher(&self) -> &RosPublisher<T> {
        &self.publisher
    }
}

impl<T: RosMessage> LifecyclePublisher<T> {
    /// Publish `msg` if the node is active; resolve with `.wait()` or
    /// `.await`: `Ok(Some(outcome))` when sent, `Ok(None)` when not.
    pub fn publish<'p>(&'p self, msg: &'p T) -> LifecyclePublish<'p, T> {
        LifecyclePublish {
            publisher: self,
            msg,
        }
    }

    /// Whether to send now; warns at the first refusal of an inactive spell.
    fn admit(&self) -> bool {
        if self.is_active() {
            self.warned.store(false, Ordering::Relaxed);
            return true;
        }
        if !self.warned.swap(true, Ordering::Relaxed) {
            tracing::warn!(
                key_expr = self.publisher.key_expr(),
                "a lifecycle publisher was asked to publish while its node is not active: nothing was sent"
            );
        }
        false
    }
}

/// One pending publish of a [`LifecyclePublisher`]; resolve with `.wait()`
/// or `.await`.
#[must_use = "resolve the publish with .wait() or .await"]
pub struct LifecyclePublish<'p, T> {
    publisher: &'p LifecyclePublisher<T>,
    msg: &'p T,
}

impl<T: RosMessage> Resolvable for LifecyclePublish<'_, T> {
    type To = Result<Option<PublishOutcome>, PublishError>;
}

impl<T: RosMessage> Wait for LifecyclePublish<'_, T> {
    fn wait(self) -> Self::To {
        if !self.publisher.admit() {
            return Ok(None);
        }
        self.publisher.publisher.publish(self.msg).wait().map(Some)
    }
}

impl<'p, T: RosMessage> std::future::IntoFuture for LifecyclePublish<'p, T> {
    type Output = Result<Option<PublishOutcome>, PublishError>;
    type IntoFuture =
        std::pin::Pin<Box<dyn std::future::Future<Output = Self::Output> + Send + 'p>>;

    fn into_future(self) -> Self::IntoFuture {
        if !self.publisher.admit() {
            return Box::pin(std::future::ready(Ok(None)));
        }
        let publish = self.publisher.publisher.publish(self.msg).into_future();
        Box::pin(async move { publish.await.map(Some) })
    }
}
