//! How each subscribing process receives a publisher's shared memory, with the
//! processes (and users, and limits) apart: start a subscriber, then one
//! publisher process per topic.
//!
//! ```text
//! shm_reach subscribe <port> <count> <topic>...        listens on tcp/127.0.0.1:<port>
//! shm_reach publish <port> <count> <topic> <pool KiB>  connects to it
//! ```
//!
//! The publisher prints how the subscribing session receives its pool's
//! messages (`Reach`) and where its messages went; the subscriber prints,
//! per topic, how many of `count` arrived and how many through shared
//! memory, and fails if one is missing. `.ci/unprivileged` runs it across
//! two users and with a subscriber whose memory-lock limit holds only one
//! of two publishers' pools.

use std::collections::HashMap;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_cdr_examples::peer_session;
use shm_runtime::ShmOptions;
use shm_runtime::{PayloadKind, SessionExt, ShmConfig, ShmContext};
use zenoh::Wait;

const MESSAGE_BYTES: usize = 64 * 1024;
const TIMEOUT: Duration = Duration::from_secs(20);

fn main() -> ExitCode {
    shm_runtime::init_logging();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["subscribe", port, count, ref topics @ ..] if !topics.is_empty() => {
            parse(port, count).and_then(|(port, count)| subscribe(port, count, topics))
        }
        ["publish", port, count, topic, pool_kib] => parse(port, count).and_then(|(port, count)| {
            let pool_kib: usize = pool_kib
                .parse()
                .map_err(|e| format!("pool size {pool_kib:?}: {e}"))?;
            publish(port, count, topic, pool_kib * 1024)
        }),
        _ => Err("usage: shm_reach subscribe <port> <count> <topic>... | shm_reach publish <port> <count> <topic> <pool KiB>".into()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("shm_reach: {e}");
            ExitCode::FAILURE
        }
    }
}

type Result<T> = zenoh::Result<T>;

fn parse(port: &str, count: &str) -> Result<(u16, usize)> {
    Ok((
        port.parse().map_err(|e| format!("port {port:?}: {e}"))?,
        count.parse().map_err(|e| format!("count {count:?}: {e}"))?,
    ))
}

fn endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

fn subscribe(port: u16, count: usize, topics: &[&str]) -> Result<()> {
    let session = peer_session(&endpoint(port), true)?;
    let subscribers = topics
        .iter()
        .map(|topic| {
            session
                .declare_ros_subscriber::<UInt8MultiArray>(*topic)
                .wait()
        })
        .collect::<zenoh::Result<Vec<_>>>()?;
    println!(
        "subscribed to {} topic(s), listening on {}",
        topics.len(),
        endpoint(port)
    );
    // One reader per topic, so that no publisher's pool waits on another's.
    let deadline = Instant::now() + TIMEOUT;
    let counts = std::thread::scope(|scope| {
        let readers: Vec<_> = topics
            .iter()
            .zip(&subscribers)
            .map(|(topic, subscriber)| {
                scope.spawn(move || -> Result<(usize, usize)> {
                    let (mut received, mut in_shm) = (0, 0);
                    while received < count {
                        let left = deadline.saturating_duration_since(Instant::now());
                        let Some(sample) = subscriber.recv_timeout(left)? else {
                            break;
                        };
                        let message: UInt8MultiArray = sample.decode()?;
                        if message.data.len() != MESSAGE_BYTES
                            || usize::from(message.data[0]) != received % 256
                        {
                            return Err(format!(
                                "{topic}: message {received} arrived out of order or corrupt"
                            )
                            .into());
                        }
                        received += 1;
                        in_shm += usize::from(sample.is_shm());
                    }
                    Ok((received, in_shm))
                })
            })
            .collect();
        readers
            .into_iter()
            .map(|reader| reader.join().map_err(|_| "a reader panicked")?)
            .collect::<Result<Vec<_>>>()
    })?;
    let mut complete = true;
    for ((topic, subscriber), (received, in_shm)) in topics.iter().zip(&subscribers).zip(counts) {
        println!(
            "{topic}: received {received} of {count}, {in_shm} through shared memory, missed {}",
            subscriber.missed()
        );
        complete &= received == count;
    }
    match complete {
        true => Ok(()),
        false => Err("messages are missing".into()),
    }
}

fn publish(port: u16, count: usize, topic: &str, pool: usize) -> Result<()> {
    let session = peer_session(&endpoint(port), false)?;
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(pool).threshold(1024))?;
    let publisher = session
        .declare_ros_publisher::<UInt8MultiArray>(topic)
        .shm(&shm)
        .wait()?;
    if !publisher.wait_for_subscribers(TIMEOUT) {
        return Err(format!("{topic}: no subscriber within {TIMEOUT:?}").into());
    }
    for receiver in publisher.receivers() {
        println!(
            "{topic}: session {} receives as {:?}",
            receiver.session, receiver.reach
        );
    }
    let mut kinds: HashMap<PayloadKind, usize> = HashMap::new();
    for i in 0..count {
        let message = UInt8MultiArray {
            data: vec![(i % 256) as u8; MESSAGE_BYTES],
            ..Default::default()
        };
        *kinds
            .entry(publisher.publish(&message).wait()?.kind)
            .or_default() += 1;
        std::thread::sleep(Duration::from_millis(10));
    }
    let mut kinds: Vec<_> = kinds
        .into_iter()
        .map(|(k, n)| format!("{k:?} {n}"))
        .collect();
    kinds.sort();
    println!("{topic}: published {count}: {}", kinds.join(", "));
    Ok(())
}
