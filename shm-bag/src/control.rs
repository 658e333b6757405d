//! Steering a playback while it runs: pause, resume, rate, single steps,
//! bursts, seeking and stopping, as `ros2 bag play`'s keyboard and
//! `rosbag2_interfaces` services do.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// A handle on a [`Player`](crate::Player)'s playback, usable from any
/// thread while [`Player::play`](crate::Player::play) runs (and before: a
/// playback paused or sped up before it starts begins that way).
///
/// Times are the recording's: nanoseconds since the Unix epoch, as the
/// messages' log times.
///
/// ```no_run
/// use std::sync::atomic::AtomicBool;
/// use shm_bag::{Bag, PlayOptions, Player};
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let options = PlayOptions { start_paused: true, ..PlayOptions::default() };
/// let player = Player::new(&session, Bag::open("my_bag".as_ref())?, options)?;
/// let control = player.control();
/// std::thread::scope(|s| {
///     let playing = s.spawn(|| player.play(&AtomicBool::new(false)));
///     control.play_next(); // the first message, now
///     control.burst(10); // the next ten, at once
///     control.set_rate(2.0);
///     control.resume(); // the rest, twice as fast as recorded
///     playing.join()
/// })
/// .expect("the playback thread panicked")?;
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
#[derive(Clone)]
pub struct PlayerControl(Arc<Control>);

impl std::fmt::Debug for PlayerControl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let state = self.0.lock();
        f.debug_struct("PlayerControl")
            .field("paused", &state.paused)
            .field("rate", &state.rate)
            .field("time", &state.time())
            .finish_non_exhaustive()
    }
}

struct Control {
    state: Mutex<State>,
    changed: Condvar,
    /// One single step at a time.
    stepping: Mutex<()>,
    /// The recording's first and last message times.
    first: u64,
    last: u64,
}

struct State {
    paused: bool,
    rate: f64,
    /// The playback's time at `anchor_wall`; while paused or before the
    /// playback starts, the time itself.
    anchor_time: u64,
    /// When the time ran from `anchor_time`; `None` before the playback.
    anchor_wall: Option<Instant>,
    /// A time to continue from, not yet taken by the playback.
    seek: Option<u64>,
    step: Step,
    playing: bool,
    stopped: bool,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Step {
    Idle,
    Requested,
    Done(bool),
}

/// What the playback does with the message it waits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Due {
    /// Its time has come: publish it.
    Play,
    /// A single step asks for it: publish it now and report
    /// ([`PlayerControl::stepped`]).
    Step,
    /// Continue from this time instead.
    Seek(u64),
    /// End the playback.
    Stop,
}

/// The longest the playback waits without looking at the caller's stop flag.
const STOP_POLL: Duration = Duration::from_millis(50);

impl State {
    fn time(&self) -> u64 {
        match self.anchor_wall {
            Some(wall) if !self.paused => {
                let ran = wall.elapsed().as_nanos() as f64 * self.rate;
                self.anchor_time.saturating_add(ran as u64)
            }
            _ => self.anchor_time,
        }
    }

    /// Hold the time where it is now, and let it run (if it runs) from here.
    fn reanchor(&mut self) {
        self.anchor_time = self.time();
        if self.anchor_wall.is_some() {
            self.anchor_wall = Some(Instant::now());
        }
    }

    fn cancel_step(&mut self) {
        if self.step == Step::Requested {
            self.step = Step::Done(false);
        }
    }
}

impl PlayerControl {
    pub(crate) fn new(first: u64, last: u64, begin: u64, rate: f64, paused: bool) -> Self {
        Self(Arc::new(Control {
            state: Mutex::new(State {
                paused,
                rate,
                anchor_time: begin,
                anchor_wall: None,
                seek: None,
                step: Step::Idle,
                playing: false,
                stopped: false,
            }),
            changed: Condvar::new(),
            stepping: Mutex::new(()),
            first,
            last,
        }))
    }

    /// Pause: no message is published until [`resume`](Self::resume) (but
    /// for [`play_next`](Self::play_next) and [`burst`](Self::burst)), and the
    /// playback's time (and `/clock`) stands still.
    pub fn pause(&self) {
        let mut state = self.0.lock();
        if !state.paused {
            state.reanchor();
            state.paused = true;
        }
        self.0.changed.notify_all();
    }

    /// Resume a paused playback from where its time stands.
    pub fn resume(&self) {
        let mut state = self.0.lock();
        if state.paused {
            state.paused = false;
            if state.anchor_wall.is_some() {
                state.anchor_wall = Some(Instant::now());
            }
            state.cancel_step();
        }
        self.0.changed.notify_all();
    }

    /// Pause a running playback, resume a paused one.
    pub fn toggle_paused(&self) {
        if self.is_paused() {
            self.resume();
        } else {
            self.pause();
        }
    }

    /// Whether the playback is paused.
    pub fn is_paused(&self) -> bool {
        self.0.lock().paused
    }

    /// How many times faster than recorded the playback runs.
    pub fn rate(&self) -> f64 {
        self.0.lock().rate
    }

    /// Run `rate` times faster than recorded from now on; `false` (and no
    /// change) unless `rate` is a finite number above 0.
    pub fn set_rate(&self, rate: f64) -> bool {
        if !(rate > 0.0 && rate.is_finite()) {
            return false;
        }
        let mut state = self.0.lock();
        state.reanchor();
        state.rate = rate;
        self.0.changed.notify_all();
        true
    }

    /// The playback's time: the recording's time it has reached (ns since
    /// the Unix epoch).
    pub fn time(&self) -> u64 {
        self.0.lock().time()
    }

    /// While paused, publish the next message now and set the playback's
    /// time to its time. Returns once it is published: `false` when not
    /// paused, when the playback is not running or has no message left, or
    /// when it is resumed, seeks or stops before the message goes out.
    pub fn play_next(&self) -> bool {
        let _one_at_a_time = self.0.stepping.lock().unwrap_or_else(|e| e.into_inner());
        let mut state = self.0.lock();
        if !state.paused || !state.playing || state.stopped {
            return false;
        }
        state.step = Step::Requested;
        self.0.changed.notify_all();
        loop {
            match state.step {
                Step::Done(published) => {
                    state.step = Step::Idle;
                    return published;
                }
                Step::Requested | Step::Idle => state = self.0.wait(state, None),
            }
        }
    }

    /// While paused, publish the next `count` messages (0: all that are
    /// left) at once, each as [`play_next`](Self::play_next). Returns how
    /// many were published.
    pub fn burst(&self, count: u64) -> u64 {
        let mut published = 0;
        while (count == 0 || published < count) && self.play_next() {
            published += 1;
        }
        published
    }

    /// Continue the playback from the recording's `time` (a time before the
    /// recording starts means its start), keeping the pause and the rate;
    /// with a start offset or a duration, their window still bounds what is
    /// played. `false` (and no change) when `time` is after the recording's
    /// last message.
    pub fn seek(&self, time: u64) -> bool {
        if time > self.0.last {
            return false;
        }
        let time = time.max(self.0.first);
        let mut state = self.0.lock();
        state.seek = Some(time);
        state.anchor_time = time;
        if state.anchor_wall.is_some() {
            state.anchor_wall = Some(Instant::now());
        }
        state.cancel_step();
        self.0.changed.notify_all();
        true
    }

    /// End the playback: [`Player::play`](crate::Player::play) returns.
    pub fn stop(&self) {
        let mut state = self.0.lock();
        state.stopped = true;
        state.cancel_step();
        self.0.changed.notify_all();
    }

    /// Whether [`stop`](Self::stop) was called.
    pub fn is_stopped(&self) -> bool {
        self.0.lock().stopped
    }

    /// A playback (pass) starts now from `begin`, or from where a seek asked;
    /// the time it starts from.
    pub(crate) fn start_pass(&self, begin: u64) -> u64 {
        let mut state = self.0.lock();
        let from = state.seek.take().unwrap_or(begin);
        state.anchor_time = from;
        state.anchor_wall = Some(Instant::now());
        state.playing = true;
        self.0.changed.notify_all();
        from
    }

    /// Wait until the message of the recording's `time` is due, or something
    /// else is asked.
    pub(crate) fn wait_due(&self, time: u64, stop: &AtomicBool) -> Due {
        let mut state = self.0.lock();
        loop {
            if state.stopped || stop.load(Ordering::Relaxed) {
                return Due::Stop;
            }
            if let Some(to) = state.seek.take() {
                return Due::Seek(to);
            }
            let wait = if state.paused {
                if state.step == Step::Requested {
                    return Due::Step;
                }
                STOP_POLL
            } else {
                let now = state.time();
                if now >= time {
                    return Due::Play;
                }
                let ahead = (time - now) as f64 / state.rate;
                Duration::from_nanos(ahead as u64).min(STOP_POLL)
            };
            state = self.0.wait(state, Some(wait));
        }
    }

    /// The message asked for by a single step, of the recording's `time`,
    /// went out (or failed to).
    pub(crate) fn stepped(&self, time: u64, published: bool) {
        let mut state = self.0.lock();
        state.anchor_time = time;
        if state.anchor_wall.is_some() {
            state.anchor_wall = Some(Instant::now());
        }
        if state.step == Step::Requested {
            state.step = Step::Done(published);
        }
        self.0.changed.notify_all();
    }

    /// The playback ended: a single step waiting for a message gets none.
    pub(crate) fn finish(&self) {
        let mut state = self.0.lock();
        state.playing = false;
        state.cancel_step();
        self.0.changed.notify_all();
    }
}

impl Control {
    fn lock(&self) -> MutexGuard<'_, State> {
        // The state stays consistent under every update: a panic elsewhere
        // while holding the lock leaves nothing half-changed.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn wait<'a>(
        &self,
        state: MutexGuard<'a, State>,
        timeout: Option<Duration>,
    ) -> MutexGuard<'a, State> {
        match timeout {
            Some(timeout) => match self.changed.wait_timeout(state, timeout) {
                Ok((state, _)) => state,
                Err(e) => e.into_inner().0,
            },
            None => self.changed.wait(state).unwrap_or_else(|e| e.into_inner()),
        }
    }
}
