//! Time as a ROS node keeps it: a [`Clock`] per node that reads system time,
//! or simulated time from `/clock` when the node uses sim time, and
//! [`Timer`]s that fire on it.

use std::fmt;
use std::ops::{Add, Sub};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use shm_cdr::msgs::builtin_interfaces::msg::Time;

use crate::CallbackSubscriber;

/// A point in time on a [`Clock`]: nanoseconds since the Unix epoch (system
/// time), or since the simulation's start (simulated time).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct RosTime {
    nanos: i64,
}

impl RosTime {
    /// The time `nanos` nanoseconds after the clock's origin.
    pub const fn from_nanos(nanos: i64) -> Self {
        Self { nanos }
    }

    /// Nanoseconds after the clock's origin.
    pub const fn nanos(self) -> i64 {
        self.nanos
    }

    /// As `builtin_interfaces/msg/Time` (a stamp).
    pub fn to_msg(self) -> Time {
        Time {
            sec: i32::try_from(self.nanos.div_euclid(1_000_000_000)).unwrap_or(i32::MAX),
            nanosec: self.nanos.rem_euclid(1_000_000_000) as u32,
        }
    }

    /// From `builtin_interfaces/msg/Time`.
    pub fn from_msg(time: &Time) -> Self {
        Self::from_nanos(i64::from(time.sec) * 1_000_000_000 + i64::from(time.nanosec))
    }

    fn system_now() -> Self {
        let since = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        Self::from_nanos(i64::try_from(since.as_nanos()).unwrap_or(i64::MAX))
    }
}

impl Add<Duration> for RosTime {
    type Output = RosTime;
    fn add(self, duration: Duration) -> RosTime {
        let nanos = i64::try_from(duration.as_nanos()).unwrap_or(i64::MAX);
        RosTime::from_nanos(self.nanos.saturating_add(nanos))
    }
}

impl Sub for RosTime {
    type Output = Duration;
    /// The time from `earlier` to `self`; zero if `earlier` is later.
    fn sub(self, earlier: RosTime) -> Duration {
        Duration::from_nanos(u64::try_from(self.nanos - earlier.nanos).unwrap_or(0))
    }
}

impl fmt::Display for RosTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let msg = self.to_msg();
        write!(f, "{}.{:09}", msg.sec, msg.nanosec)
    }
}

/// A node's ROS clock (rclcpp's `RCL_ROS_TIME`): system time, or, while the
/// node uses simulated time ([`RosNode::set_use_sim_time`](crate::RosNode::set_use_sim_time)),
/// the last time received on `/clock` (`rosgraph_msgs/msg/Clock`; zero
/// before the first). Simulated time stands still when `/clock` does, and
/// may jump back (a restarted simulation); [`Timer`]s and
/// [`sleep_until`](Self::sleep_until) follow it. Cloning gives another handle
/// to the same clock.
#[derive(Clone)]
pub struct Clock {
    inner: Arc<ClockInner>,
}

struct ClockInner {
    state: Mutex<ClockState>,
    /// Notified on every simulated tick, switch of source and timer cancel.
    changed: Condvar,
    /// The `/clock` subscription while simulated time is on.
    subscription: Mutex<Option<CallbackSubscriber<shm_cdr::msgs::rosgraph_msgs::msg::Clock>>>,
}

#[derive(Default)]
struct ClockState {
    simulated: bool,
    sim_now: RosTime,
    /// Async sleepers, woken by dropping their sender.
    wakers: Vec<flume::Sender<()>>,
}

impl fmt::Debug for Clock {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Clock")
            .field("simulated", &self.is_simulated())
            .field("now", &self.now())
            .finish()
    }
}

impl Default for Clock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock {
    /// A clock on system time.
    pub fn new() -> Self {
        Self {
            inner: Arc::new(ClockInner {
                state: Mutex::default(),
                changed: Condvar::new(),
                subscription: Mutex::new(None),
            }),
        }
    }

    fn lock(&self) -> MutexGuard<'_, ClockState> {
        // The state is whole between statements.
        self.inner.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The time now.
    pub fn now(&self) -> RosTime {
        Self::read(&self.lock())
    }

    fn read(state: &ClockState) -> RosTime {
        if state.simulated {
            state.sim_now
        } else {
            RosTime::system_now()
        }
    }

    /// Whether the clock follows `/clock`.
    pub fn is_simulated(&self) -> bool {
        self.lock().simulated
    }

    /// Follow `/clock` (from now on `now` is the last time received there)
    /// or go back to system time; every waiter re-reads the clock.
    pub(crate) fn set_simulated(
        &self,
        subscription: Option<CallbackSubscriber<shm_cdr::msgs::rosgraph_msgs::msg::Clock>>,
    ) {
        let simulated = subscription.is_some();
        let old = std::mem::replace(
            &mut *self
                .inner
                .subscription
                .lock()
                .unwrap_or_else(|e| e.into_inner()),
            subscription,
        );
        drop(old);
        let mut state = self.lock();
        if state.simulated != simulated {
            state.simulated = simulated;
            state.sim_now = RosTime::default();
        }
        self.wake(state);
    }

    /// A time received on `/clock`.
    pub(crate) fn tick(&self, time: RosTime) {
        let mut state = self.lock();
        if state.simulated {
            state.sim_now = time;
            self.wake(state);
        }
    }

    fn wake(&self, mut state: MutexGuard<'_, ClockState>) {
        state.wakers.clear();
        drop(state);
        self.inner.changed.notify_all();
    }

    /// Block until the clock reads `deadline` or later (on simulated time:
    /// until `/clock` gets there), until it goes back before `since`, or
    /// until `stop` is set. No polling: the thread sleeps until the deadline
    /// on system time, or until the next tick on simulated time.
    fn wait_until(&self, since: RosTime, deadline: RosTime, stop: &AtomicBool) -> Waited {
        let mut state = self.lock();
        loop {
            if stop.load(Ordering::SeqCst) {
                return Waited::Stopped;
            }
            let now = Self::read(&state);
            if now >= deadline {
                return Waited::Reached(now);
            }
            if now < since {
                return Waited::WentBack(now);
            }
            state = if state.simulated {
                self.inner
                    .changed
                    .wait(state)
                    .unwrap_or_else(|e| e.into_inner())
            } else {
                self.inner
                    .changed
                    .wait_timeout(state, deadline - now)
                    .unwrap_or_else(|e| e.into_inner())
                    .0
            };
        }
    }

    /// Block until the clock reads `deadline` or later.
    pub fn sleep_until(&self, deadline: RosTime) {
        let never = AtomicBool::new(false);
        self.wait_until(RosTime::from_nanos(i64::MIN), deadline, &never);
    }

    /// Resolves once the clock reads `deadline` or later; no polling, any
    /// async runtime. Cancellation-safe.
    pub async fn sleep_until_async(&self, deadline: RosTime) {
        loop {
            let woken = {
                let mut state = self.lock();
                let now = Self::read(&state);
                if now >= deadline {
                    return;
                }
                let (sender, receiver) = flume::bounded::<()>(1);
                state.wakers.push(sender);
                if state.simulated {
                    Wake::Tick(receiver)
                } else {
                    Wake::Deadline(receiver, futures_timer::Delay::new(deadline - now))
                }
            };
            match woken {
                // Nothing is sent: the sender is dropped on a tick or a switch.
                Wake::Tick(receiver) => {
                    let _ = receiver.recv_async().await;
                }
                Wake::Deadline(receiver, delay) => {
                    let tick = std::pin::pin!(receiver.into_recv_async());
                    let _ = first_of(tick, delay).await;
                }
            }
        }
    }

    /// A handle that does not keep the clock alive (for the `/clock`
    /// callback, which the clock itself holds).
    pub(crate) fn tick_handle(&self) -> impl Fn(RosTime) + Send + Sync + 'static {
        let weak = Arc::downgrade(&self.inner);
        move |time| {
            if let Some(inner) = weak.upgrade() {
                Clock { inner }.tick(time);
            }
        }
    }

    /// Wake every waiter so it re-reads its stop flag.
    fn interrupt(&self) {
        let state = self.lock();
        self.wake(state);
    }
}

/// How a [`Clock::wait_until`] ended.
enum Waited {
    Reached(RosTime),
    WentBack(RosTime),
    Stopped,
}

enum Wake {
    Tick(flume::Receiver<()>),
    Deadline(flume::Receiver<()>, futures_timer::Delay),
}

/// Whichever of two futures finishes first.
async fn first_of<A, B>(a: A, b: B)
where
    A: std::future::Future + Unpin,
    B: std::future::Future + Unpin,
{
    let (mut a, mut b) = (a, b);
    std::future::poll_fn(move |cx| {
        if std::pin::Pin::new(&mut a).poll(cx).is_ready()
            || std::pin::Pin::new(&mut b).poll(cx).is_ready()
        {
            std::task::Poll::Ready(())
        } else {
            std::task::Poll::Pending
        }
    })
    .await
}

/// A callback called every `period` on a [`Clock`], on a thread of the
/// timer's own, as rclcpp's timers: on ROS time it follows simulated time
/// (it does not fire while `/clock` stands still; a period that `/clock`
/// skips over fires once), on a jump back it starts over from the new time.
/// Made by [`RosNode::create_timer`](crate::RosNode::create_timer) (the node's
/// ROS clock) and [`RosNode::create_wall_timer`](crate::RosNode::create_wall_timer)
/// (system time); stops when dropped or [`cancel`](Self::cancel)led, after
/// which its callback is not called again.
pub struct Timer {
    shared: Arc<TimerShared>,
    clock: Clock,
    thread: Option<std::thread::JoinHandle<()>>,
}

struct TimerShared {
    stop: AtomicBool,
    fired: AtomicU64,
    period: Duration,
}

impl fmt::Debug for Timer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Timer")
            .field("period", &self.shared.period)
            .field("fired", &self.fired())
            .field("canceled", &self.is_canceled())
            .finish()
    }
}

impl Timer {
    pub(crate) fn start(
        clock: Clock,
        period: Duration,
        mut callback: impl FnMut() + Send + 'static,
    ) -> std::io::Result<Self> {
        let shared = Arc::new(TimerShared {
            stop: AtomicBool::new(false),
            fired: AtomicU64::new(0),
            period: period.max(Duration::from_nanos(1)),
        });
        let (thread_clock, thread_shared) = (clock.clone(), shared.clone());
        // The first period starts now, not when the thread gets to run.
        let started = clock.now();
        let thread = std::thread::Builder::new()
            .name("ros-timer".into())
            .spawn(move || {
                let (clock, shared) = (thread_clock, thread_shared);
                // `anchor`: the last deadline (the grid periods count from);
                // `since`: the clock's last reading, to notice a jump back.
                let mut since = started;
                let mut anchor = started;
                loop {
                    let next = next_deadline(anchor, clock.now(), shared.period);
                    match clock.wait_until(since, next, &shared.stop) {
                        Waited::Stopped => return,
                        // A jump back (a restarted simulation): start over.
                        Waited::WentBack(now) => (since, anchor) = (now, now),
                        Waited::Reached(now) => {
                            if catch_unwind(AssertUnwindSafe(&mut callback)).is_err() {
                                tracing::error!("a timer callback panicked; the timer goes on");
                            }
                            shared.fired.fetch_add(1, Ordering::Relaxed);
                            (since, anchor) = (now, next);
                        }
                    }
                }
            })?;
        Ok(Self {
            shared,
            clock,
            thread: Some(thread),
        })
    }

    /// How many times the callback was called.
    pub fn fired(&self) -> u64 {
        self.shared.fired.load(Ordering::Relaxed)
    }

    /// The period.
    pub fn period(&self) -> Duration {
        self.shared.period
    }

    /// Stop: the callback is not called again (one running now finishes).
    pub fn cancel(&self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.clock.interrupt();
    }

    /// Whether [`cancel`](Self::cancel) was called.
    pub fn is_canceled(&self) -> bool {
        self.shared.stop.load(Ordering::SeqCst)
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        self.cancel();
        if let Some(thread) = self.thread.take() {
            // Dropped from its own callback: the thread ends after it returns.
            if thread.thread().id() != std::thread::current().id() {
                let _ = thread.join();
            }
        }
    }
}

/// The next deadline after `last` (a deadline, or where the timer started),
/// the clock reading `now`: one period on, past every period `now` skipped
/// over; if `now` is before `last`, one period after `now`.
fn next_deadline(last: RosTime, now: RosTime, period: Duration) -> RosTime {
    let period_ns = i64::try_from(period.as_nanos()).unwrap_or(i64::MAX).max(1);
    if now < last {
        return now + period;
    }
    let skipped = (now.nanos() - last.nanos()) / period_ns;
    RosTime::from_nanos(
        last.nanos()
            .saturating_add(period_ns.saturating_mul(skipped.saturating_add(1))),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_convert_to_stamps_and_back() {
        let t = RosTime::from_nanos(1_700_000_000_123_456_789);
        assert_eq!(t.to_msg().sec, 1_700_000_000);
        assert_eq!(t.to_msg().nanosec, 123_456_789);
        assert_eq!(RosTime::from_msg(&t.to_msg()), t);
        assert_eq!(t.to_string(), "1700000000.123456789");
        assert_eq!((t + Duration::from_millis(1)) - t, Duration::from_millis(1));
        assert_eq!(t - (t + Duration::from_secs(1)), Duration::ZERO);
    }

    #[test]
    fn a_late_timer_skips_the_periods_it_missed_and_restarts_after_a_jump_back() {
        let s = |secs: i64| RosTime::from_nanos(secs * 1_000_000_000);
        let period = Duration::from_secs(1);
        assert_eq!(next_deadline(s(1), s(1), period), s(2));
        assert_eq!(next_deadline(s(1), s(3), period), s(4));
        assert_eq!(next_deadline(s(5), s(2), period), s(3));
    }
}
