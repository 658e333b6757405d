//! Cross-process latency of a PointCloud2: the publish call in one process → the
//! subscriber in another process holding the decoded message, one message in
//! flight, under several Zenoh configurations.
//!
//! `cargo bench -p shm-cdr-examples --bench cross_process --features hiroz`
//! (without `--features hiroz`, hiroz's rows are left out; `-- --quick` runs a
//! fifth of the rounds, `-- --setups default,recommended` a subset, and
//! `-- --idle-us N` makes the ping wait N µs, spinning, after building each
//! message and before the clock starts, so the echo has been idle that long when
//! the message comes: what a topic at a few hundred Hz or less sees).
//!
//! This process only orchestrates. For each [`common::Setup`] it starts two
//! children of this same binary, each a fresh process so that `ZENOH_RUNTIME`
//! applies: the *ping* (publishers, listening) and the *echo* (subscribers,
//! connecting). For every message the ping takes CLOCK_MONOTONIC right before
//! the publish call (after the message was built: see each path), the echo takes
//! it once it holds the decoded message, checks every byte, releases the sample
//! and answers with a 18-byte pong carrying its time. The ping waits for that
//! pong before the next message. The paths take turns in a fresh random order
//! every round, so drift hits them alike, and each sends an untimed lead-in
//! before its timed message: what a message leaves behind (caches, the pool's
//! free chunks, the echo's threads) differs a lot from path to path, and the
//! timed one then follows one of its own, as in an application publishing one
//! topic. (With a fixed order every path always followed the same other one:
//! that alone moved the 8 MiB ratios by up to 0.2.)
//! Every message is checked byte for byte: a wrong one fails the run, and so does
//! a lost one except under lowlatency (which cannot fragment; it is reported).
//! Under lowlatency, plain puts of heap payloads of 64 KiB and more are not sent
//! at all (see [`common::UNFRAGMENTABLE_FROM`]). A cell whose messages our pool
//! could not take says how many went out from the heap. Medians and p90s, printed
//! as Markdown, and the median of per-round ratios for the splice, the loan and
//! the floors; with the default and recommended
//! setups in the run, `cross_process.svg` is written next to the crate's manifest.

mod common;
#[cfg(feature = "hiroz")]
mod hiroz;
mod ours;

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{
    Path, Pong, Setup, DONE_KEY, PONG_KEY, PONG_TIMEOUT, POOL, SETUPS, SIZES, UNFRAGMENTABLE_FROM,
};
use shm_runtime::{ShmConfig, ShmContext};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Wait;

/// One way of publishing, seen from the ping: build message `seq` (before the
/// clock), then send it (on the clock).
pub trait Sender {
    fn path(&self) -> Path;
    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()>;
    fn send(&mut self) -> zenoh::Result<()>;
}

const WARMUP: usize = 20;

fn rounds(bytes: usize, quick: bool) -> usize {
    let full = match bytes {
        b if b >= 8 << 20 => 150,
        b if b >= 1 << 20 => 300,
        _ => 500,
    };
    if quick {
        full / 5
    } else {
        full
    }
}

fn main() {
    let outcome = match std::env::var("XPROC_ROLE").as_deref() {
        Ok("ping") => ping(),
        Ok("echo") => echo(),
        _ => orchestrate(),
    };
    if let Err(e) = outcome {
        eprintln!("cross_process: {e}");
        std::process::exit(1);
    }
}

/// What the orchestrator hands each child.
fn child_env(key: &str) -> zenoh::Result<String> {
    std::env::var(key).map_err(|_| format!("{key} is not set").into())
}

fn ping() -> zenoh::Result<()> {
    zenoh::try_init_log_from_env();
    let setup = Setup::by_name(&child_env("XPROC_SETUP")?).ok_or("unknown setup")?;
    let quick = std::env::var_os("XPROC_QUICK").is_some();
    let idle_ns = match std::env::var("XPROC_IDLE_US") {
        Ok(us) => us.parse::<u64>()? * 1000,
        Err(_) => 0,
    };
    let session = zenoh::open(setup.config(&child_env("XPROC_OURS")?, true)?).wait()?;
    let shm = ShmContext::new(ShmConfig::enabled().pool_size(POOL))?;
    let pongs = session.declare_subscriber(PONG_KEY).wait()?;
    let done = session.declare_publisher(DONE_KEY).wait()?;
    let ours = ours::Publishers::declare(&session, &shm)?;
    #[cfg(feature = "hiroz")]
    let theirs = hiroz::Publishers::declare(&setup, &child_env("XPROC_HIROZ")?)?;
    println!("LISTENING");

    let mut senders = ours.senders(&shm);
    #[cfg(feature = "hiroz")]
    senders.extend(theirs.senders());

    let mut seq = 0u64;
    settle_all(&mut senders, &pongs, &mut seq)?;
    // (size, path) → (round, latency ns) of every measured message.
    let mut samples: BTreeMap<(usize, u8), Vec<(usize, u64)>> = BTreeMap::new();
    // (size, path) → measured messages our pool could not take (heap fallbacks).
    let mut spilled: BTreeMap<(usize, u8), usize> = BTreeMap::new();
    let mut lost = BTreeSet::new();
    let mut unsent = BTreeSet::new();
    let mut resettle = false;
    // Seeded: a rerun sends in the same orders.
    let mut order = fastrand::Rng::with_seed(0x5eed);
    for (bytes, _) in SIZES {
        for round in 0..WARMUP + rounds(bytes, quick) {
            // A fresh order every round: what ran before leaves caches, the
            // allocator and the echo's threads behind, and a fixed cyclic order
            // (even rotated) would give every path the same predecessor each time.
            order.shuffle(&mut senders);
            if std::mem::take(&mut resettle) {
                // The receiver closes the whole transport on a frame it refuses,
                // so every path waits for the peers to reconnect before going on.
                settle_all(&mut senders, &pongs, &mut seq)?;
            }
            for sender in senders.iter_mut() {
                if resettle {
                    // An earlier path this round was lost: the rest would be too.
                    break;
                }
                let path = sender.path();
                if lost.contains(&(bytes, path as u8)) {
                    continue;
                }
                if setup.lowlatency && path.puts_heap() && bytes >= UNFRAGMENTABLE_FROM {
                    // Zenoh cannot fragment under lowlatency: the receiver drops
                    // a heap payload larger than a batch and closes the whole
                    // transport, which Zenoh 1.10.2 here sometimes did not
                    // reopen within 20 s. So these are not sent; that they are
                    // lost is shown by end_to_end.rs.
                    if unsent.insert((bytes, path as u8)) {
                        println!("UNSENT\t{}\t{bytes}", path as u8);
                    }
                    continue;
                }
                // An untimed lead-in first: the timed message then follows one
                // of its own path, as in an application publishing one topic, not
                // whatever another path left behind in the caches and the pool.
                for timed in [false, true] {
                    seq += 1;
                    let spilled_before = spilled_count(&shm);
                    let Some(took) = round_trip(sender.as_mut(), bytes, seq, idle_ns, &pongs)?
                    else {
                        // A setup that cannot carry this message (lowlatency does
                        // not fragment) loses it: say so, and go on with the other
                        // paths once the peers have reconnected (next round).
                        println!("LOST\t{}\t{bytes}", path as u8);
                        lost.insert((bytes, path as u8));
                        resettle = true;
                        break;
                    };
                    if timed && round >= WARMUP {
                        samples
                            .entry((bytes, path as u8))
                            .or_default()
                            .push((round, took));
                        if spilled_count(&shm) > spilled_before {
                            *spilled.entry((bytes, path as u8)).or_default() += 1;
                        }
                    }
                }
            }
        }
    }
    for (&(bytes, path), timed) in &samples {
        let mut ns: Vec<u64> = timed.iter().map(|&(_, ns)| ns).collect();
        ns.sort_unstable();
        let at = |q: f64| ns[((ns.len() - 1) as f64 * q) as usize] as f64 / 1e3;
        println!(
            "RESULT\t{path}\t{bytes}\t{:.1}\t{:.1}\t{}\t{}",
            at(0.5),
            at(0.9),
            ns.len(),
            spilled.get(&(bytes, path)).copied().unwrap_or(0)
        );
    }
    for (num, den) in PAIRS {
        for (bytes, _) in SIZES {
            let (Some(a), Some(b)) = (
                samples.get(&(bytes, num as u8)),
                samples.get(&(bytes, den as u8)),
            ) else {
                continue;
            };
            if let Some(ratio) = paired_median_ratio(a, b) {
                println!("PAIRED\t{}\t{}\t{bytes}\t{ratio:.4}", num as u8, den as u8);
            }
        }
    }
    done.put(vec![1u8]).wait()?;
    Ok(())
}

/// Build message `seq` on `sender`'s path, then time it from the publish call
/// to the echo holding it decoded; `None` if it never arrived.
fn round_trip(
    sender: &mut dyn Sender,
    bytes: usize,
    seq: u64,
    idle_ns: u64,
    pongs: &Subscriber<FifoChannelHandler<Sample>>,
) -> zenoh::Result<Option<u64>> {
    sender.prepare(bytes, seq)?;
    // Spin rather than sleep: only the echo's side goes idle.
    let idle_until = common::now_ns() + idle_ns;
    while common::now_ns() < idle_until {
        std::hint::spin_loop();
    }
    let start = common::now_ns();
    sender.send()?;
    let Some(pong) = wait_pong(pongs, sender.path(), seq, PONG_TIMEOUT)? else {
        return Ok(None);
    };
    let took = pong
        .at_ns
        .checked_sub(start)
        .ok_or("the echo's clock ran backwards")?;
    Ok(Some(took))
}

/// Messages our pool sent to the heap so far (full pool, or larger than it).
fn spilled_count(shm: &ShmContext) -> u64 {
    let stats = shm.stats();
    stats.fallbacks + stats.too_large
}

/// The pairs compared round by round (numerator, denominator).
const PAIRS: [(Path, Path); 4] = [
    (Path::Splice, Path::Floor),
    (Path::Splice, Path::FloorFragments),
    (Path::FloorFragments, Path::Floor),
    (Path::Loan, Path::Floor),
];

/// The median over rounds of `a`'s latency over `b`'s in the same round. Both
/// ran within one round, a few hundred µs apart, so host drift slower than that
/// cancels out; the ratio of the two medians does not have that property.
fn paired_median_ratio(a: &[(usize, u64)], b: &[(usize, u64)]) -> Option<f64> {
    let by_round: BTreeMap<usize, u64> = b.iter().copied().collect();
    let mut ratios: Vec<f64> = a
        .iter()
        .filter_map(|(round, ns)| {
            let other = *by_round.get(round)?;
            (other > 0).then(|| *ns as f64 / other as f64)
        })
        .collect();
    if ratios.is_empty() {
        return None;
    }
    ratios.sort_unstable_by(f64::total_cmp);
    Some(ratios[ratios.len() / 2])
}

/// Publish small messages on one path until the echo answers one: discovery,
/// matching and the first SHM mapping are done before anything is timed.
/// Settle every path. Another project's path whose echo never answers is
/// reported (`FAILED`) and left out of the rest of the run, so that its row
/// says so and every other row is still measured; one of ours failing fails
/// the run.
fn settle_all<'a>(
    senders: &mut Vec<Box<dyn Sender + 'a>>,
    pongs: &Subscriber<FifoChannelHandler<Sample>>,
    seq: &mut u64,
) -> zenoh::Result<()> {
    let mut failed = Vec::new();
    for (i, sender) in senders.iter_mut().enumerate() {
        if let Err(e) = settle(sender.as_mut(), pongs, seq) {
            let path = sender.path();
            if !path.is_theirs() {
                return Err(e);
            }
            println!("FAILED\t{}\t{e}", path as u8);
            failed.push(i);
        }
    }
    for i in failed.into_iter().rev() {
        senders.remove(i);
    }
    Ok(())
}

fn settle(
    sender: &mut dyn Sender,
    pongs: &Subscriber<FifoChannelHandler<Sample>>,
    seq: &mut u64,
) -> zenoh::Result<()> {
    let deadline = Instant::now() + Duration::from_secs(20);
    while Instant::now() < deadline {
        *seq += 1;
        sender.prepare(64, *seq)?;
        sender.send()?;
        if wait_pong(pongs, sender.path(), *seq, Duration::from_millis(250))?.is_some() {
            return Ok(());
        }
    }
    Err(format!("{:?}: the echo never answered", sender.path()).into())
}

/// The pong of message `seq` on `path`, skipping late pongs of earlier
/// messages; an error if the echo found the message wrong.
fn wait_pong(
    pongs: &Subscriber<FifoChannelHandler<Sample>>,
    path: Path,
    seq: u64,
    timeout: Duration,
) -> zenoh::Result<Option<Pong>> {
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let Some(sample) = pongs.recv_timeout(left)? else {
            return Ok(None);
        };
        let pong = Pong::parse(&sample.payload().to_bytes()).ok_or("malformed pong")?;
        if pong.path != path as u8 {
            continue;
        }
        if !pong.ok {
            return Err(format!(
                "{path:?}: the echo received message {} wrong (expected {seq})",
                pong.seq
            )
            .into());
        }
        if pong.seq == seq {
            return Ok(Some(pong));
        }
    }
}

fn echo() -> zenoh::Result<()> {
    zenoh::try_init_log_from_env();
    let setup = Setup::by_name(&child_env("XPROC_SETUP")?).ok_or("unknown setup")?;
    let session = zenoh::open(setup.config(&child_env("XPROC_OURS")?, false)?).wait()?;
    let pong = Arc::new(session.declare_publisher(PONG_KEY).wait()?);
    let done = session.declare_subscriber(DONE_KEY).wait()?;
    let _ours = ours::echo(&session, &pong, setup.callback)?;
    #[cfg(feature = "hiroz")]
    let _theirs = hiroz::echo(&setup, &child_env("XPROC_HIROZ")?, &pong)?;
    // Receiving threads block in `recv` until the process ends.
    done.recv()?;
    Ok(())
}

/// One measured cell: median and p90 in µs.
#[derive(Clone, Copy, Debug)]
struct Cell {
    median: f64,
    p90: f64,
    /// Messages measured.
    count: usize,
    /// Of those, how many our pool could not take (published from the heap).
    spilled: usize,
    /// The setup did not deliver this message at all.
    lost: bool,
    /// Not sent: the setup cannot carry it (see `UNFRAGMENTABLE_FROM`).
    unsent: bool,
    /// Not measured: the path's echo (another project's) never answered.
    failed: bool,
}

impl Cell {
    /// A message the setup did not deliver.
    fn lost() -> Cell {
        Cell {
            lost: true,
            ..Cell::unmeasured()
        }
    }

    /// A path whose echo never answered.
    fn failed() -> Cell {
        Cell {
            failed: true,
            ..Cell::unmeasured()
        }
    }

    /// A message not sent, because the setup cannot carry it.
    fn unsent() -> Cell {
        Cell {
            unsent: true,
            ..Cell::unmeasured()
        }
    }

    fn unmeasured() -> Cell {
        Cell {
            median: f64::NAN,
            p90: f64::NAN,
            count: 0,
            spilled: 0,
            lost: false,
            unsent: false,
            failed: false,
        }
    }

    fn measured(&self) -> bool {
        !self.lost && !self.unsent && !self.failed
    }
}

/// What one setup measured.
#[derive(Default)]
struct Results {
    /// (size, path) → its cell.
    cells: BTreeMap<(usize, u8), Cell>,
    /// (size, numerator path, denominator path) → median of per-round ratios.
    paired: BTreeMap<(usize, u8, u8), f64>,
    /// Why another project's paths were left out.
    failures: Vec<String>,
}

fn orchestrate() -> zenoh::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let idle_us: Option<u64> = match args.iter().position(|a| a == "--idle-us") {
        Some(i) => Some(args.get(i + 1).ok_or("--idle-us needs a number")?.parse()?),
        None => None,
    };
    let chosen: Vec<Setup> = match args.iter().position(|a| a == "--setups") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--setups needs a comma-separated list")?
            .split(',')
            .map(|name| Setup::by_name(name).ok_or_else(|| format!("no setup named {name:?}")))
            .collect::<Result<_, _>>()?,
        None => SETUPS.to_vec(),
    };
    let exe = std::env::current_exe()?;
    let mut all: Vec<(Setup, Results)> = Vec::new();
    for (i, setup) in chosen.iter().enumerate() {
        eprintln!("setup {:?} ...", setup.name);
        let Some(results) = run_setup(&exe, setup, i, quick, idle_us)? else {
            continue;
        };
        print_setup(setup, &results);
        all.push((*setup, results));
    }
    print_summary(&all);
    plot(&all);
    Ok(())
}

fn endpoints(setup: &Setup, index: usize) -> (String, String) {
    if setup.unix_socket {
        let base =
            std::env::temp_dir().join(format!("shm-cdr-xproc-{}-{index}", std::process::id()));
        let ours = format!("{}-ours.sock", base.display());
        let hiroz = format!("{}-hiroz.sock", base.display());
        for file in [&ours, &hiroz] {
            let _ = std::fs::remove_file(file);
        }
        (
            format!("unixsock-stream/{ours}"),
            format!("unixsock-stream/{hiroz}"),
        )
    } else {
        let port = 27_700 + 2 * index as u16;
        (
            format!("tcp/127.0.0.1:{port}"),
            format!("tcp/127.0.0.1:{}", port + 1),
        )
    }
}

fn child(
    exe: &std::path::Path,
    role: &str,
    setup: &Setup,
    eps: &(String, String),
    quick: bool,
    idle_us: Option<u64>,
) -> zenoh::Result<Child> {
    let mut command = Command::new(exe);
    command
        .env("XPROC_ROLE", role)
        .env("XPROC_SETUP", setup.name)
        .env("XPROC_OURS", &eps.0)
        .env("XPROC_HIROZ", &eps.1)
        .stdin(Stdio::null())
        .stdout(if role == "ping" {
            Stdio::piped()
        } else {
            Stdio::null()
        });
    // XPROC_ZENOH_RUNTIME, for experiments: one ZENOH_RUNTIME for every setup.
    match std::env::var("XPROC_ZENOH_RUNTIME")
        .ok()
        .or(setup.runtime.map(String::from))
    {
        Some(runtime) => command.env("ZENOH_RUNTIME", runtime),
        None => command.env_remove("ZENOH_RUNTIME"),
    };
    if quick {
        command.env("XPROC_QUICK", "1");
    }
    if let Some(us) = idle_us {
        command.env("XPROC_IDLE_US", us.to_string());
    }
    Ok(command.spawn()?)
}

fn run_setup(
    exe: &std::path::Path,
    setup: &Setup,
    index: usize,
    quick: bool,
    idle_us: Option<u64>,
) -> zenoh::Result<Option<Results>> {
    // Held open for the whole setup: the kernel keeps the request while the file
    // is open (see the kernel's PM QoS documentation).
    let _no_idle_halts = if setup.idle_halts {
        None
    } else {
        match hold_cpu_wakeup_latency_zero() {
            Ok(file) => Some(file),
            Err(e) => {
                println!(
                    "\n### {}: skipped, /dev/cpu_dma_latency is not writable here ({e}; it needs root)",
                    setup.name
                );
                return Ok(None);
            }
        }
    };
    let eps = endpoints(setup, index);
    let mut ping = child(exe, "ping", setup, &eps, quick, idle_us)?;
    let stdout = ping.stdout.take().ok_or("ping without stdout")?;
    let mut lines = BufReader::new(stdout).lines();
    let mut echo: Option<Child> = None;
    let mut results = Results::default();
    for line in &mut lines {
        let line = line?;
        if line == "LISTENING" {
            echo = Some(child(exe, "echo", setup, &eps, quick, idle_us)?);
        } else if let Some(fields) = line.strip_prefix("RESULT\t") {
            let f: Vec<&str> = fields.split('\t').collect();
            let [path, bytes, median, p90, count, spilled] = f[..] else {
                return Err(format!("malformed result line {line:?}").into());
            };
            let key = (bytes.parse()?, path.parse()?);
            // What a path measured before its echo failed is left out with it.
            if results.cells.get(&key).is_some_and(|c| c.failed) {
                continue;
            }
            results.cells.insert(
                key,
                Cell {
                    median: median.parse()?,
                    p90: p90.parse()?,
                    count: count.parse()?,
                    spilled: spilled.parse()?,
                    lost: false,
                    unsent: false,
                    failed: false,
                },
            );
        } else if let Some(fields) = line.strip_prefix("PAIRED\t") {
            let f: Vec<&str> = fields.split('\t').collect();
            let [num, den, bytes, ratio] = f[..] else {
                return Err(format!("malformed paired line {line:?}").into());
            };
            results
                .paired
                .insert((bytes.parse()?, num.parse()?, den.parse()?), ratio.parse()?);
        } else if let Some(fields) = line.strip_prefix("LOST\t") {
            let (path, bytes) = fields.split_once('\t').ok_or("malformed LOST line")?;
            results
                .cells
                .insert((bytes.parse()?, path.parse()?), Cell::lost());
        } else if let Some(fields) = line.strip_prefix("FAILED\t") {
            let (path, reason) = fields.split_once('\t').ok_or("malformed FAILED line")?;
            let path: u8 = path.parse()?;
            // Every size of the path, measured before the failure or not.
            for (bytes, _) in SIZES {
                results.cells.insert((bytes, path), Cell::failed());
            }
            results.failures.push(reason.to_owned());
        } else if let Some(fields) = line.strip_prefix("UNSENT\t") {
            let (path, bytes) = fields.split_once('\t').ok_or("malformed UNSENT line")?;
            results
                .cells
                .insert((bytes.parse()?, path.parse()?), Cell::unsent());
        }
    }
    let status = ping.wait()?;
    if let Some(mut echo) = echo {
        let deadline = Instant::now() + Duration::from_secs(10);
        while echo.try_wait()?.is_none() {
            if Instant::now() > deadline {
                eprintln!("the echo did not exit; killing it");
                let _ = echo.kill();
                let _ = echo.wait();
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    if !status.success() {
        return Err(format!("setup {:?}: the ping failed ({status})", setup.name).into());
    }
    // Only lowlatency is allowed to lose messages (it cannot fragment): anywhere
    // else a lost message is a failure, not a table cell.
    if !setup.lowlatency {
        if let Some(((bytes, path), _)) = results.cells.iter().find(|(_, c)| c.lost) {
            let path = Path::from_u8(*path).map_or("?", Path::label);
            return Err(
                format!("setup {:?}: {path} lost a {bytes}-byte message", setup.name).into(),
            );
        }
    }
    Ok(Some(results))
}

/// Ask the kernel for a CPU wake-up latency of 0 µs while the returned file is
/// open: idle CPUs then poll instead of halting.
fn hold_cpu_wakeup_latency_zero() -> std::io::Result<std::fs::File> {
    use std::io::Write;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/cpu_dma_latency")?;
    file.write_all(&0i32.to_ne_bytes())?;
    Ok(file)
}

fn paths_in(results: &Results) -> Vec<Path> {
    Path::ALL
        .into_iter()
        .filter(|p| results.cells.keys().any(|(_, q)| *q == *p as u8))
        .collect()
}

fn print_setup(setup: &Setup, results: &Results) {
    println!("\n### {} ({})\n", setup.name, describe(setup));
    print!("| path |");
    for (_, name) in SIZES {
        print!(" {name} |");
    }
    println!();
    println!("|---|{}", "---:|".repeat(SIZES.len()));
    for path in paths_in(results) {
        print!("| {} |", path.label());
        for (bytes, _) in SIZES {
            match results.cells.get(&(bytes, path as u8)) {
                Some(c) if c.lost => print!(" **lost** |"),
                Some(c) if c.failed => print!(" **its echo never answered** |"),
                Some(c) if c.unsent => print!(" not sent |"),
                Some(c) if c.spilled > 0 => print!(
                    " {:.0} µs (p90 {:.0}), **{} of {} from the heap** |",
                    c.median, c.p90, c.spilled, c.count
                ),
                Some(c) => print!(" {:.0} µs (p90 {:.0}) |", c.median, c.p90),
                None => print!(" – |"),
            }
        }
        println!();
    }
    for reason in &results.failures {
        println!("\nLeft out: {reason}.");
    }
}

fn describe(setup: &Setup) -> String {
    let mut parts = vec![if setup.unix_socket {
        "unix socket"
    } else {
        "TCP 127.0.0.1"
    }
    .to_string()];
    if !setup.qos {
        parts.push("qos off".into());
    }
    if setup.lowlatency {
        parts.push("lowlatency".into());
    }
    if !setup.batching {
        parts.push("batching off".into());
    }
    if setup.callback {
        parts.push("callback subscribers".into());
    }
    if let Some(runtime) = setup.runtime {
        parts.push(format!("ZENOH_RUNTIME='{runtime}'"));
    }
    if !setup.idle_halts {
        parts.push("no idle halts: /dev/cpu_dma_latency held at 0".into());
    }
    parts.join(", ")
}

fn median_of(all: &[(Setup, Results)], setup: &str, bytes: usize, path: Path) -> Option<f64> {
    let (_, results) = all.iter().find(|(s, _)| s.name == setup)?;
    results
        .cells
        .get(&(bytes, path as u8))
        .filter(|c| c.measured())
        .map(|c| c.median)
}

/// Each knob against the default, on the paths that matter, at 1 MiB and 64 B;
/// then the goals.
fn print_summary(all: &[(Setup, Results)]) {
    println!(
        "\n### Each setup against the default (median ratio default / setup; > 1 is faster)\n"
    );
    let probes = [
        (64usize, Path::Loan),
        (64, Path::Floor),
        (1 << 20, Path::Loan),
        (1 << 20, Path::Floor),
        (1 << 20, Path::Automatic),
    ];
    print!("| setup |");
    for (bytes, path) in probes {
        print!(" {} {} |", path.label(), size_name(bytes));
    }
    println!();
    println!("|---|{}", "---:|".repeat(probes.len()));
    for (setup, _) in all {
        print!("| {} |", setup.name);
        for (bytes, path) in probes {
            match (
                median_of(all, "default", bytes, path),
                median_of(all, setup.name, bytes, path),
            ) {
                (Some(base), Some(this)) => print!(" {:.2}× |", base / this),
                _ => print!(" – |"),
            }
        }
        println!();
    }
    let mib = 1 << 20;
    let loan_best = median_of(all, "recommended", mib, Path::Loan);
    let loan_default = median_of(all, "default", mib, Path::Loan);
    println!();
    for setup in [
        "recommended",
        "recommended + lowlatency",
        "recommended + no idle halts",
        "recommended + lowlatency + no idle halts",
    ] {
        if let (Some(this), Some(default)) = (median_of(all, setup, mib, Path::Loan), loan_default)
        {
            println!(
                "1 MiB loan: default {default:.0} µs → {setup} {this:.0} µs = {:.2}× faster",
                default / this
            );
        }
    }
    for hiroz in [Path::HirozAutomatic, Path::HirozShm] {
        for setup in ["default", "recommended"] {
            if let (Some(best), Some(theirs)) = (loan_best, median_of(all, setup, mib, hiroz)) {
                println!("1 MiB: {} under {setup} {theirs:.0} µs / our recommended loan {best:.0} µs = {:.2}×", hiroz.label(), theirs / best);
            }
        }
    }
    println!("\nRatios of medians, and in brackets the median of per-round ratios:");
    for (setup, results) in all {
        for bytes in [mib, 8 * mib] {
            let parts: Vec<String> = PAIRS
                .iter()
                .filter_map(|&(num, den)| {
                    let a = median_of(all, setup.name, bytes, num)?;
                    let b = median_of(all, setup.name, bytes, den)?;
                    let paired = results.paired.get(&(bytes, num as u8, den as u8))?;
                    Some(format!(
                        "{}/{} {:.2}× ({paired:.2}×)",
                        num.short(),
                        den.short(),
                        a / b
                    ))
                })
                .collect();
            if !parts.is_empty() {
                println!("{}, {}: {}", setup.name, size_name(bytes), parts.join(", "));
            }
        }
    }
}

fn size_name(bytes: usize) -> &'static str {
    SIZES
        .iter()
        .find(|(b, _)| *b == bytes)
        .map_or("?", |(_, n)| n)
}

/// Median vs size, log-log: the default setup dashed, the recommended one solid.
fn plot(all: &[(Setup, Results)]) {
    use plotters::prelude::*;
    let (Some((_, default)), Some((_, best))) = (
        all.iter().find(|(s, _)| s.name == "default"),
        all.iter().find(|(s, _)| s.name == "recommended"),
    ) else {
        return;
    };
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/cross_process.svg");
    let root = SVGBackend::new(path, (820, 480)).into_drawing_area();
    let _ = root.fill(&WHITE);
    let max = default
        .cells
        .values()
        .chain(best.cells.values())
        .map(|c| c.median)
        .fold(1.0, f64::max);
    let min = default
        .cells
        .values()
        .chain(best.cells.values())
        .map(|c| c.median)
        .fold(f64::MAX, f64::min);
    let Ok(mut chart) = ChartBuilder::on(&root)
        .caption(
            "PointCloud2 across processes: publish → decoded, median µs (dashed: Zenoh default, solid: recommended)",
            ("sans-serif", 15),
        )
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d((0.04..12_000.0).log_scale(), ((min * 0.7)..max * 1.5).log_scale())
    else {
        return;
    };
    let _ = chart
        .configure_mesh()
        .x_desc("data size (KiB)")
        .y_desc("latency (µs)")
        .draw();
    let colors = [
        RED,
        BLUE,
        GREEN,
        MAGENTA,
        BLACK,
        RGBColor(230, 140, 0),
        RGBColor(120, 60, 0),
        RGBColor(128, 128, 128),
    ];
    for (path, color) in Path::ALL.into_iter().zip(colors) {
        let series = |results: &Results| -> Vec<(f64, f64)> {
            SIZES
                .iter()
                .filter_map(|(b, _)| {
                    results
                        .cells
                        .get(&(*b, path as u8))
                        .filter(|c| c.measured())
                        .map(|c| (*b as f64 / 1024.0, c.median))
                })
                .collect()
        };
        let (dashed, solid) = (series(default), series(best));
        if solid.is_empty() {
            continue;
        }
        let _ = chart.draw_series(DashedLineSeries::new(dashed, 6, 4, color.stroke_width(1)));
        if let Ok(drawn) = chart.draw_series(LineSeries::new(solid.clone(), color.stroke_width(2)))
        {
            drawn
                .label(path.label())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], color));
        }
        let _ = chart.draw_series(solid.iter().map(|p| Circle::new(*p, 3, color.filled())));
    }
    let _ = chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw();
    let _ = root.present();
    println!("\nplot written to {path}");
}
