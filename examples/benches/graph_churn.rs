//! What a process keeps of the graph after entities leave: heap and resident
//! memory of an observing session while another process's endpoints, under
//! names never seen before, appear and leave in rounds, and after that
//! process exits.
//!
//! Two observers, each in a process of its own: a plain Zenoh session (the
//! reference: what Zenoh itself keeps) and the same session holding a
//! [`GraphCache`]. The churning process declares 2 000 publisher tokens with
//! 3.8 KB topic names per round (rmw_zenoh_cpp allows tokens up to 4 KB), then undeclares them, three rounds; its
//! session stays open until the end, as a long-running process's (or a
//! router's) does.
//!
//! `cargo bench -p shm-cdr-examples --bench graph_churn` prints the table.

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicIsize, Ordering};
use std::time::{Duration, Instant};

use shm_cdr::msgs::std_msgs::String as RosString;
use shm_runtime::graph::GraphCache;
use shm_runtime::rmw::{Distro, EntityKind, NodeInfo, Qos};
use zenoh::{Config, Wait};

#[global_allocator]
static ALLOCATOR: shm_cdr_examples::heap::Counting = shm_cdr_examples::heap::Counting;

const TOKENS: usize = 2_000;
const NAME_LEN: usize = 3_800;
const ROUNDS: usize = 3;
const TIMEOUT: Duration = Duration::from_secs(60);

fn config(key: &str, port: u16) -> Config {
    let mut c = Config::default();
    for (k, v) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".into()),
        ("transport/shared_memory/enabled", "false".into()),
        (key, format!("[\"tcp/127.0.0.1:{port}\"]")),
    ] {
        c.insert_json5(k, &v).expect("config");
    }
    c
}

fn resident_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kib: f64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .unwrap_or(f64::NAN);
    kib / 1024.0
}

fn heap_mib() -> f64 {
    shm_cdr_examples::heap::live_bytes() as f64 / (1 << 20) as f64
}

/// Hands the pages glibc's allocator keeps for reuse back to the system.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn give_back_freed_pages() {
    extern "C" {
        fn malloc_trim(pad: usize) -> i32;
    }
    // SAFETY: glibc's malloc_trim takes any padding and only releases free
    // memory; nothing of the caller's is touched.
    unsafe {
        malloc_trim(0);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn give_back_freed_pages() {}

/// The churning process: reads a command per line from stdin ("up", "down",
/// "exit") and answers "ok" once done.
fn churn(port: u16) {
    let session = zenoh::open(config("connect/endpoints", port))
        .wait()
        .expect("open");
    let zid = session.zid().to_string();
    let mut round = 0;
    let mut held = Vec::new();
    for line in std::io::stdin().lock().lines() {
        match line.expect("stdin").as_str() {
            "up" => {
                for i in 0..TOKENS {
                    let node = NodeInfo {
                        domain_id: 0,
                        zid: zid.clone(),
                        node_id: (i / 50) as u64,
                        enclave: "/".into(),
                        namespace: "/churn".into(),
                        name: format!("node_{round}_{}", i / 50),
                        distro: Distro::Kilted,
                    };
                    let topic = format!("/{}_{round}_{i}", "x".repeat(NAME_LEN));
                    let token = node.topic_token::<RosString>(
                        i as u64 + 1,
                        EntityKind::Publisher,
                        &topic,
                        &Qos::default(),
                    );
                    held.push(
                        session
                            .liveliness()
                            .declare_token(token)
                            .wait()
                            .expect("token"),
                    );
                }
                round += 1;
            }
            "down" => held.clear(),
            _ => break,
        }
        println!("ok");
    }
}

/// The observing process: with or without a graph cache, counts the tokens
/// it sees and prints its memory at each stage the driver asks for.
fn observe(port: u16, with_cache: bool) {
    let session = zenoh::open(config("listen/endpoints", port))
        .wait()
        .expect("open");
    let cache = with_cache.then(|| GraphCache::of(&session, 0).expect("graph cache"));
    let seen = std::sync::Arc::new(AtomicIsize::new(0));
    let counter = seen.clone();
    let _subscriber = session
        .liveliness()
        .declare_subscriber("@ros2_lv/0/**")
        .callback(move |sample| {
            let step = if sample.kind() == zenoh::sample::SampleKind::Put {
                1
            } else {
                -1
            };
            counter.fetch_add(step, Ordering::Relaxed);
        })
        .wait()
        .expect("subscriber");
    println!("ready");
    for line in std::io::stdin().lock().lines() {
        let line = line.expect("stdin");
        if line == "trim" {
            give_back_freed_pages();
            println!("{:.1} {:.1}", heap_mib(), resident_mib());
            continue;
        }
        let want: isize = match line.parse() {
            Ok(n) => n,
            Err(_) => break,
        };
        let deadline = Instant::now() + TIMEOUT;
        while seen.load(Ordering::Relaxed) != want
            || cache
                .as_ref()
                .is_some_and(|c| c.read().len() as isize != want)
        {
            assert!(Instant::now() < deadline, "tokens never reached {want}");
            std::thread::sleep(Duration::from_millis(20));
        }
        // Let Zenoh's own threads finish with the news.
        std::thread::sleep(Duration::from_millis(500));
        println!("{:.1} {:.1}", heap_mib(), resident_mib());
    }
}

struct Child {
    process: std::process::Child,
    lines: std::io::Lines<BufReader<std::process::ChildStdout>>,
}

impl Child {
    fn spawn(args: &[&str]) -> Self {
        let mut process = Command::new(std::env::current_exe().expect("own path"))
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("spawn");
        let lines = BufReader::new(process.stdout.take().expect("stdout")).lines();
        Self { process, lines }
    }
    fn tell(&mut self, line: &str) {
        let stdin = self.process.stdin.as_mut().expect("stdin");
        writeln!(stdin, "{line}").expect("write");
        stdin.flush().expect("flush");
    }
    fn ask(&mut self, line: &str) -> String {
        self.tell(line);
        self.read()
    }
    fn read(&mut self) -> String {
        self.lines.next().expect("an answer").expect("read")
    }
}

fn run(observer_kind: &str, port: u16) -> Vec<(String, String)> {
    let mut observer = Child::spawn(&["observe", observer_kind, &port.to_string()]);
    assert_eq!(observer.read(), "ready");
    let mut rows = vec![("before".to_owned(), observer.ask("0"))];
    let mut churner = Child::spawn(&["churn", &port.to_string()]);
    for round in 1..=ROUNDS {
        assert_eq!(churner.ask("up"), "ok");
        rows.push((
            format!("round {round}: {TOKENS} appeared"),
            observer.ask(&TOKENS.to_string()),
        ));
        assert_eq!(churner.ask("down"), "ok");
        rows.push((format!("round {round}: all left"), observer.ask("0")));
    }
    churner.tell("exit");
    let _ = churner.process.wait();
    // The churning session is gone once the observer's transport notices.
    std::thread::sleep(Duration::from_secs(2));
    rows.push(("the churning process exited".to_owned(), observer.ask("0")));
    rows.push(("then `malloc_trim(0)`".to_owned(), observer.ask("trim")));
    observer.tell("exit");
    let _ = observer.process.wait();
    rows
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("churn") => return churn(args[2].parse().expect("port")),
        Some("observe") => return observe(args[3].parse().expect("port"), args[2] == "cache"),
        _ => {}
    }
    let plain = run("plain", 7881);
    let cache = run("cache", 7882);
    println!(
        "{TOKENS} endpoint tokens with {NAME_LEN}-byte topic names per round, new names each round; \
         heap / resident MiB of the observing process"
    );
    println!();
    println!("| stage | plain Zenoh session | with a GraphCache |");
    println!("|---|---:|---:|");
    for ((stage, p), (_, c)) in plain.iter().zip(&cache) {
        let cell = |s: &str| {
            let mut it = s.split(' ');
            format!(
                "{} / {}",
                it.next().unwrap_or("?"),
                it.next().unwrap_or("?")
            )
        };
        println!("| {stage} | {} | {} |", cell(p), cell(c));
    }
}
