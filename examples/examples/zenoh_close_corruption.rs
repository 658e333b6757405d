//! A Zenoh-only reproducer (no shm-cdr, no shm-runtime): a reliable
//! `CongestionControl::Block` publisher whose subscriber process is SIGSTOPped
//! past `wait_before_close`, then SIGCONTed, can deliver a message whose tail is
//! the start of the next batch on the wire.
//!
//! ```text
//! cargo run --release -p shm-cdr-examples --example zenoh_close_corruption -- [runs]
//! ```
//!
//! Every payload is 32 KiB whose bytes are a function of the message number (in
//! its first 4 bytes) and the position, so the subscriber checks each one whole.
//! Each run prints how many arrived, how many never did and how many carried
//! wrong bytes, and where the first wrong byte was.
//!
//! Why (read in zenoh-transport 1.10.2, `unicast/universal/link.rs`): the tx task
//! runs `write_loop` under `CancellationToken::run_until_cancelled`. When the
//! congested transport is closed, the token cancels it in the middle of
//! `send_batch`, i.e. of a `write_all` of one length-prefixed batch that the full
//! socket accepted only in part. The task then drains the pipeline and writes
//! the remaining batches to the same stream. The receiver reads the truncated
//! batch's length and takes the next batch's first bytes as its tail.

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use zenoh::qos::{CongestionControl, Reliability};
use zenoh::{Config, Wait};

const CHILD_ENV: &str = "ZENOH_CLOSE_CORRUPTION_CHILD";
const KEY: &str = "repro/close";
const SIZE: usize = 32 * 1024;
/// Published while the subscriber process is stopped.
const DURING_STOP: u32 = 1000;
/// The subscriber stops counting at this message, well past the reconnection.
const DONE_AT: u32 = DURING_STOP + 300;
const STOPPED: Duration = Duration::from_secs(7);

fn byte(i: u32, k: usize) -> u8 {
    (i as usize).wrapping_mul(31).wrapping_add(k) as u8
}

fn payload(i: u32) -> Vec<u8> {
    let mut data: Vec<u8> = (0..SIZE).map(|k| byte(i, k)).collect();
    data[..4].copy_from_slice(&i.to_le_bytes());
    data
}

fn config(port: u16, listen: bool) -> Config {
    let mut c = Config::default();
    let endpoints = format!("[\"tcp/127.0.0.1:{port}\"]");
    let set = |c: &mut Config, key: &str, value: &str| {
        c.insert_json5(key, value)
            .unwrap_or_else(|e| panic!("{key}: {e}"))
    };
    set(&mut c, "mode", "\"peer\"");
    set(&mut c, "scouting/multicast/enabled", "false");
    // Zenoh's implicit copy of large payloads into shared memory is a different
    // matter (its unsafe garbage collection): keep it out.
    set(
        &mut c,
        "transport/shared_memory/transport_optimization/enabled",
        "false",
    );
    let key = if listen {
        "listen/endpoints"
    } else {
        "connect/endpoints"
    };
    set(&mut c, key, &endpoints);
    c
}

/// The subscriber process: check every payload, report once past `DONE_AT`.
fn child(port: u16) -> ! {
    let session = zenoh::open(config(port, false)).wait().expect("open");
    let (tx, rx) = mpsc::channel::<Vec<u8>>();
    let _subscriber = session
        .declare_subscriber(KEY)
        .callback(move |sample| {
            let _ = tx.send(sample.payload().to_bytes().into_owned());
        })
        .wait()
        .expect("subscriber");
    std::thread::spawn(|| {
        let _ = std::io::copy(&mut std::io::stdin(), &mut std::io::sink());
        std::process::exit(0);
    });
    println!("ready");
    let (mut received, mut next, mut lost, mut corrupted) = (0u32, 0u32, 0u32, 0u32);
    while next <= DONE_AT {
        let Ok(data) = rx.recv_timeout(Duration::from_secs(30)) else {
            break;
        };
        let Some(i) = data
            .get(..4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        else {
            corrupted += 1;
            continue;
        };
        let wrong = (data.len() != SIZE)
            .then_some(data.len().min(SIZE))
            .or_else(|| (4..SIZE).find(|&k| data[k] != byte(i, k)));
        if let Some(at) = wrong {
            corrupted += 1;
            eprintln!(
                "message {i}: {} bytes, wrong from byte {at}: {:02x?}",
                data.len(),
                &data[at..data.len().min(at + 24)]
            );
        }
        if i >= next {
            lost += i - next;
            next = i + 1;
        }
        received += 1;
    }
    println!("done received {received} lost {lost} corrupted {corrupted}");
    loop {
        std::thread::sleep(Duration::from_secs(60));
    }
}

fn signal(pid: u32, name: &str) {
    let status = Command::new("sh")
        .args(["-c", &format!("kill {name} {pid}")])
        .status()
        .expect("sh");
    assert!(status.success(), "kill {name} {pid}");
}

/// One stop: returns the child's report line.
fn run() -> String {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("free port")
        .port();
    let session = zenoh::open(config(port, true)).wait().expect("open");
    let publisher = session
        .declare_publisher(KEY)
        .reliability(Reliability::Reliable)
        .congestion_control(CongestionControl::Block)
        .wait()
        .expect("publisher");
    let mut process = Command::new(std::env::current_exe().expect("current exe"))
        .env(CHILD_ENV, port.to_string())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn");
    let (lines_tx, lines) = mpsc::channel();
    let stdout = process.stdout.take().expect("stdout");
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = lines_tx.send(line);
        }
    });
    assert_eq!(
        lines.recv_timeout(Duration::from_secs(20)).as_deref(),
        Ok("ready")
    );
    let matched = Instant::now();
    while !publisher
        .matching_status()
        .wait()
        .is_ok_and(|s| s.matching())
    {
        assert!(matched.elapsed() < Duration::from_secs(20), "no match");
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(500));
    let put = |i: u32| publisher.put(payload(i)).wait().expect("put");
    for i in 0..100 {
        put(i);
    }
    signal(process.id(), "-STOP");
    let stopped_at = Instant::now();
    for i in 100..DURING_STOP {
        put(i);
    }
    std::thread::sleep(STOPPED.saturating_sub(stopped_at.elapsed()));
    signal(process.id(), "-CONT");
    let mut i = DURING_STOP;
    let report = loop {
        if let Ok(line) = lines.try_recv() {
            break line;
        }
        assert!(i < DURING_STOP + 20_000, "the subscriber never finished");
        put(i);
        i += 1;
        std::thread::sleep(Duration::from_millis(2));
    };
    let _ = process.kill();
    let _ = process.wait();
    report
}

fn main() {
    if let Ok(port) = std::env::var(CHILD_ENV) {
        child(port.parse().expect("port"));
    }
    let runs: u32 = std::env::args()
        .nth(1)
        .map(|n| n.parse().expect("runs: a number"))
        .unwrap_or(4);
    let mut with_corruption = 0;
    for run_number in 1..=runs {
        let report = run();
        println!("run {run_number}: {report}");
        let _ = std::io::stdout().flush();
        if !report.ends_with("corrupted 0") {
            with_corruption += 1;
        }
    }
    println!("{with_corruption} of {runs} runs delivered a message with wrong bytes");
}
