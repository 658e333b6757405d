//! The guide's example of recording and playback (docs/src/recording.md),
//! compiled here word for word.
#![allow(dead_code)]

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use shm_bag::{Bag, PlayOptions, Player, RecordOptions, Recorder, Selection};

/// Record every topic under /camera for ten seconds, then play it back.
fn record_and_play(session: &zenoh::Session) -> Result<(), shm_bag::Error> {
    let selection = Selection {
        regex: Some(regex::Regex::new("^/camera")?),
        ..Selection::default()
    };
    let recorder = Recorder::start(session, RecordOptions::new("cams", selection))?;
    std::thread::sleep(Duration::from_secs(10));
    let stats = recorder.stats();
    let metadata = recorder.stop()?;
    println!(
        "{} messages, {} dropped, {} missed",
        metadata.message_count, stats.dropped, stats.missed
    );

    // At its recorded pace, with its recorded QoS.
    let player = Player::new(session, Bag::open("cams".as_ref())?, PlayOptions::default())?;
    let played = player.play(&AtomicBool::new(false))?;
    println!(
        "{} played, {} from shared memory",
        played.published, played.shm
    );
    Ok(())
}
