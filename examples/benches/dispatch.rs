//! What handing a sample to the callback's thread costs: the round trip of a
//! small message when the echo side answers from
//!
//! - a plain Zenoh callback (the floor: nothing of ours),
//! - `callback_inline` (our subscriber, on Zenoh's thread),
//! - `callback` (our subscriber's queue, then an `Executor` thread: the
//!   default),
//! - `recv()` in a thread of the application's.
//!
//! Two peer sessions in this process over TCP loopback; the pinger is plain
//! Zenoh and the same for every path; the paths take turns in a new order
//! every round so all see the same machine.
//!
//! `cargo bench -p shm-cdr-examples --bench dispatch` prints medians and p90s.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_cdr_examples::peer_session;
use shm_runtime::SessionExt;
use zenoh::{Session, Wait};

const ROUNDS: usize = 5000;
const TIMEOUT: Duration = Duration::from_secs(10);
const PATHS: [&str; 4] = [
    "zenoh callback (floor)",
    "callback_inline",
    "callback (executor)",
    "recv() thread",
];

fn sessions() -> (Session, Session) {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let a = peer_session(&endpoint, true).expect("open");
    let b = peer_session(&endpoint, false).expect("open");
    (a, b)
}

fn percentile(samples: &mut [Duration], q: f64) -> f64 {
    samples.sort_unstable();
    samples[((samples.len() - 1) as f64 * q) as usize].as_secs_f64() * 1e6
}

fn main() {
    let (pinger, echo) = sessions();
    let message = shm_cdr::to_vec(&UInt8MultiArray {
        data: vec![7; 64],
        ..Default::default()
    })
    .expect("encode");
    let (pong_tx, pong_rx) = mpsc::channel::<()>();
    let _pongs = pinger
        .declare_subscriber("dispatch/pong")
        .callback(move |_| {
            let _ = pong_tx.send(());
        })
        .wait()
        .expect("pong subscriber");
    let pong = echo
        .declare_publisher("dispatch/pong")
        .wait()
        .expect("pong publisher");
    let pong = std::sync::Arc::new(pong);

    let mut alive: Vec<Box<dyn std::any::Any>> = Vec::new();
    let answer = {
        let pong = pong.clone();
        move || {
            pong.put(Vec::<u8>::new()).wait().expect("pong");
        }
    };
    let key = |i: usize| format!("dispatch/ping/{i}");
    let a = answer.clone();
    alive.push(Box::new(
        echo.declare_subscriber(key(0))
            .callback(move |_| a())
            .wait()
            .expect("floor"),
    ));
    let a = answer.clone();
    alive.push(Box::new(
        echo.declare_ros_subscriber::<UInt8MultiArray>(key(1))
            .callback_inline(move |sample| {
                let _: UInt8MultiArray = sample.decode().expect("decode");
                a()
            })
            .wait()
            .expect("inline"),
    ));
    let a = answer.clone();
    alive.push(Box::new(
        echo.declare_ros_subscriber::<UInt8MultiArray>(key(2))
            .callback(move |sample| {
                let _: UInt8MultiArray = sample.decode().expect("decode");
                a()
            })
            .wait()
            .expect("executor"),
    ));
    let subscriber = echo
        .declare_ros_subscriber::<UInt8MultiArray>(key(3))
        .wait()
        .expect("recv");
    let a = answer.clone();
    std::thread::spawn(move || {
        while let Ok(sample) = subscriber.recv() {
            let _: UInt8MultiArray = sample.decode().expect("decode");
            a();
        }
    });

    let publishers: Vec<_> = (0..PATHS.len())
        .map(|i| pinger.declare_publisher(key(i)).wait().expect("ping"))
        .collect();
    std::thread::sleep(Duration::from_millis(500));
    let mut times: Vec<Vec<Duration>> = vec![Vec::with_capacity(ROUNDS); PATHS.len()];
    let mut order: Vec<usize> = (0..PATHS.len()).collect();
    for round in 0..ROUNDS + 200 {
        // A new order every round: no path always follows another.
        fastrand::shuffle(&mut order);
        for &path in &order {
            let publisher = &publishers[path];
            let started = Instant::now();
            publisher.put(message.clone()).wait().expect("ping");
            pong_rx.recv_timeout(TIMEOUT).expect("a pong");
            if round >= 200 {
                times[path].push(started.elapsed());
            }
        }
    }
    println!("| echo side | median round trip | p90 | median over the floor |");
    println!("|---|---:|---:|---:|");
    let floor = percentile(&mut times[0], 0.5);
    for (path, samples) in PATHS.iter().zip(&mut times) {
        let median = percentile(samples, 0.5);
        println!(
            "| {path} | {median:.1} µs | {:.1} µs | {:+.1} µs |",
            percentile(samples, 0.9),
            median - floor
        );
    }
    drop(alive);
}
