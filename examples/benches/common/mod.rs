//! What the benchmarks that run several processes share: one clock for all
//! of them, each process's CPU time, their children, their options.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

use shm_cdr_examples::peer_session;
use shm_runtime::{RosNode, ShmConfig, ShmContext};
use zenoh::{Session, Wait};

/// The publishing process's side: a peer session listening on a free TCP
/// port of loopback (its endpoint, for the children), a pool of `pool`
/// bytes, and a node named `name` using it.
pub struct Publishing {
    pub endpoint: String,
    pub session: Session,
    pub shm: ShmContext,
    pub node: RosNode,
}

impl Publishing {
    pub fn open(name: &str, pool: usize) -> zenoh::Result<Publishing> {
        let port = std::net::TcpListener::bind("127.0.0.1:0")?
            .local_addr()?
            .port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let session = peer_session(&endpoint, true)?;
        let shm = ShmContext::new(ShmConfig::enabled().pool_size(pool))?;
        let node = RosNode::builder(&session, name).shm(&shm).wait()?;
        Ok(Publishing {
            endpoint,
            session,
            shm,
            node,
        })
    }
}

/// CLOCK_MONOTONIC in nanoseconds, one clock for every process.
pub fn now_ns() -> u64 {
    use nix::time::{clock_gettime, ClockId};
    // CLOCK_MONOTONIC always exists on Linux; a failure would be a broken kernel.
    let t = clock_gettime(ClockId::CLOCK_MONOTONIC).expect("CLOCK_MONOTONIC");
    t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64
}

/// CPU time this process has used, in nanoseconds (all its threads).
pub fn cpu_ns() -> u64 {
    use nix::time::{clock_gettime, ClockId};
    // Every Linux has this clock; a failure would be a broken kernel.
    let t = clock_gettime(ClockId::CLOCK_PROCESS_CPUTIME_ID).expect("CLOCK_PROCESS_CPUTIME_ID");
    t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64
}

/// Another process of this same binary with `env` set, once it has printed
/// `READY` (its sessions and subscribers declared).
pub fn spawn_ready(env: &[(&str, &str)]) -> zenoh::Result<Child> {
    let mut command = Command::new(std::env::current_exe()?);
    command.envs(env.iter().copied()).stdout(Stdio::piped());
    let mut child = command.spawn()?;
    let ready = child
        .stdout
        .take()
        .map(|out| BufReader::new(out).lines().next());
    if !matches!(ready, Some(Some(Ok(ref line))) if line == "READY") {
        let _ = child.kill();
        return Err("a child process did not start".into());
    }
    Ok(child)
}

/// The comma-separated values after `flag` among the arguments, if it is there.
pub fn list_arg<T: std::str::FromStr>(flag: &str) -> zenoh::Result<Option<Vec<T>>>
where
    T::Err: std::fmt::Display,
{
    let args: Vec<String> = std::env::args().collect();
    let Some(i) = args.iter().position(|a| a == flag) else {
        return Ok(None);
    };
    let list = args
        .get(i + 1)
        .ok_or_else(|| format!("{flag} needs a comma-separated list"))?;
    list.split(',')
        .map(|item| {
            item.parse::<T>()
                .map_err(|e| format!("{flag} {item:?}: {e}").into())
        })
        .collect::<zenoh::Result<Vec<T>>>()
        .map(Some)
}

/// The median (of an even count, the mean of the middle two).
pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    match values.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => values[n / 2],
        n => (values[n / 2 - 1] + values[n / 2]) / 2.0,
    }
}
