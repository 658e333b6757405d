//! The keyboard controls of `bag play` and `bag record`, those of `ros2 bag`:
//! space pauses and resumes; in playback, → publishes the next message
//! (while paused), ↑ and ↓ change the rate by 0.1.
//!
//! The terminal leaves canonical mode and echo while the playback runs, and
//! keeps its signals: Ctrl-C still stops the playback.

use std::io::{IsTerminal, Read};
use std::os::fd::AsFd;

use rustix::termios::{self, LocalModes, OptionalActions, SpecialCodeIndex, Termios};
use shm_bag::{PlayerControl, RecorderControl};

/// A key `bag play` or `bag record` acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Key {
    Space,
    Right,
    Up,
    Down,
}

/// What the keys do in playback, as `ros2 bag play` lists it at the start.
pub(crate) const PLAY_HELP: &str = "\
Press SPACE for Pause/Resume
Press CURSOR_RIGHT for Play Next Message
Press CURSOR_UP for Increase Rate 10%
Press CURSOR_DOWN for Decrease Rate 10%";

/// What the keys do in recording, as `ros2 bag record` says it.
pub(crate) const RECORD_HELP: &str = "Press SPACE for pausing/resuming";

/// Splits terminal input into [`Key`]s: a space, or the cursor keys' escape
/// sequences (`ESC [ A` and, in application mode, `ESC O A`). Anything else
/// is skipped.
#[derive(Debug, Default)]
pub(crate) struct KeyReader {
    /// How far into an escape sequence the input is.
    escape: u8,
}

impl KeyReader {
    pub(crate) fn push(&mut self, byte: u8) -> Option<Key> {
        match (self.escape, byte) {
            (_, 0x1b) => {
                self.escape = 1;
                None
            }
            (1, b'[' | b'O') => {
                self.escape = 2;
                None
            }
            (2, b'A' | b'B' | b'C' | b'D') => {
                self.escape = 0;
                match byte {
                    b'A' => Some(Key::Up),
                    b'B' => Some(Key::Down),
                    b'C' => Some(Key::Right),
                    _ => None,
                }
            }
            (0, b' ') => Some(Key::Space),
            _ => {
                self.escape = 0;
                None
            }
        }
    }
}

/// Act on `key` as `ros2 bag record` does; what to tell the user.
pub(crate) fn record_key(control: &RecorderControl, key: Key) -> Option<String> {
    (key == Key::Space).then(|| {
        control.toggle_paused();
        if control.is_paused() {
            "Pausing recording.".to_owned()
        } else {
            "Resuming recording.".to_owned()
        }
    })
}

/// Act on `key` as `ros2 bag play` does; what to tell the user.
pub(crate) fn play_key(control: &PlayerControl, key: Key) -> Option<String> {
    Some(match key {
        Key::Space => {
            control.toggle_paused();
            if control.is_paused() {
                "Pausing play.".to_owned()
            } else {
                "Resuming play.".to_owned()
            }
        }
        Key::Right => {
            if !control.is_paused() {
                "Called play next, but not in paused state.".to_owned()
            } else if control.play_next() {
                "Played the next message.".to_owned()
            } else {
                "No message left to play.".to_owned()
            }
        }
        Key::Up | Key::Down => {
            let step = if key == Key::Up { 0.1 } else { -0.1 };
            // Rounded, so that steps of 0.1 land on tenths (1.2, not
            // 1.2000000000000002).
            let rate = ((control.rate() + step) * 1e6).round() / 1e6;
            if control.set_rate(rate) {
                format!("Set rate to {rate}")
            } else {
                format!("Failed to set rate to invalid value {rate}")
            }
        }
    })
}

/// The terminal's settings before the controls changed them; put back when
/// dropped.
pub(crate) struct KeyboardControls {
    saved: Termios,
}

impl Drop for KeyboardControls {
    fn drop(&mut self) {
        if let Err(e) =
            termios::tcsetattr(std::io::stdin().as_fd(), OptionalActions::Now, &self.saved)
        {
            eprintln!("could not restore the terminal's settings: {e}");
        }
    }
}

/// Read keys from the terminal on a thread of their own, print `help`, and
/// hand each key to `act`, printing what it says; `None` when standard input
/// is not a terminal, or not this process's (started in the background with
/// `&`: reading it would stop the process), or cannot be set up: the verb
/// then runs without keys.
pub(crate) fn start<F>(help: &str, mut act: F) -> Option<KeyboardControls>
where
    F: FnMut(Key) -> Option<String> + Send + 'static,
{
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        return None;
    }
    // A terminal that is not our controlling one (no process group of its
    // own for us) sends no job-control stops: keys are safe there too.
    if termios::tcgetpgrp(stdin.as_fd()).is_ok_and(|group| group != rustix::process::getpgrp()) {
        return None;
    }
    let saved = termios::tcgetattr(stdin.as_fd()).ok()?;
    let mut keys = saved.clone();
    keys.local_modes &= !(LocalModes::ICANON | LocalModes::ECHO);
    keys.special_codes[SpecialCodeIndex::VMIN] = 1;
    keys.special_codes[SpecialCodeIndex::VTIME] = 0;
    if let Err(e) = termios::tcsetattr(stdin.as_fd(), OptionalActions::Now, &keys) {
        eprintln!("keyboard controls are off: cannot set up the terminal: {e}");
        return None;
    }
    eprintln!("{help}");
    // Detached: it blocks in `read` until a key comes, and the process ends
    // after the verb whether or not one does.
    std::thread::spawn(move || {
        let mut reader = KeyReader::default();
        let mut byte = [0u8; 1];
        let mut stdin = std::io::stdin().lock();
        while let Ok(1) = stdin.read(&mut byte) {
            if let Some(said) = reader.push(byte[0]).and_then(&mut act) {
                eprintln!("{said}");
            }
        }
    });
    Some(KeyboardControls { saved })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(input: &[u8]) -> Vec<Key> {
        let mut reader = KeyReader::default();
        input.iter().filter_map(|&b| reader.push(b)).collect()
    }

    #[test]
    fn space_and_the_cursor_keys_in_either_mode_are_keys_and_the_rest_is_skipped() {
        assert_eq!(
            keys(b" \x1b[C\x1bOA\x1b[Bx\x1b[D\x1b\x1b[A q"),
            [
                Key::Space,
                Key::Right,
                Key::Up,
                Key::Down,
                Key::Up,
                Key::Space
            ]
        );
        // The byte that breaks an escape sequence goes with it.
        assert_eq!(keys(b"\x1b[ "), []);
        assert_eq!(keys(b"\x1b "), []);
        assert_eq!(keys(b"\x1bx "), [Key::Space]);
    }
}
