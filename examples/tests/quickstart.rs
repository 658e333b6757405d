//! The README's programs: the quick start's code is `examples/quickstart.rs`,
//! word for word, and a talker and a listener started from it exchange
//! messages through shared memory in two processes; the main example says
//! where each of its messages went, and means it.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The README's quick-start program is the example file: they cannot drift.
#[test]
fn the_readme_quick_start_is_the_example() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let example = std::fs::read_to_string(root.join("examples/examples/quickstart.rs")).unwrap();
    let start = readme
        .find("```rust,no_run\n")
        .expect("the quick start's code block")
        + 15;
    let len = readme[start..].find("```\n").expect("its end");
    let block = &readme[start..start + len];
    // The file adds a module comment for readers of the repository.
    let code = example
        .lines()
        .skip_while(|line| line.starts_with("//!"))
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(block.trim_end(), code.trim_end());
}

/// The example built next to this test (`cargo test` builds examples).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(Path::parent).unwrap();
    let path = dir.join("examples").join(name);
    assert!(
        path.exists(),
        "{} is not built: `cargo test --workspace` builds it, as does `cargo build -p shm-cdr-examples --example {name}`",
        path.display()
    );
    path
}

/// The log lines at warning level or above.
fn warnings(log: &str) -> Vec<&str> {
    log.lines()
        .filter(|l| l.contains(" WARN ") || l.contains(" ERROR "))
        .collect()
}

/// Waits for `child` at most `limit`, killing it past that; its stdout and
/// stderr, and whether it succeeded.
fn finish(mut child: Child, limit: Duration) -> (bool, String, String) {
    let deadline = Instant::now() + limit;
    while child.try_wait().unwrap().is_none() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let out = child.wait_with_output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A free TCP port on the loopback interface.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The quick start as the README runs it: a router, a talker and a listener,
/// configured as ROS 2's processes are (here only the router's port is
/// changed, through `ZENOH_CONFIG_OVERRIDE`); the ROS tools meeting at the
/// router see both nodes.
#[test]
fn a_talker_and_a_listener_exchange_the_users_struct_through_shared_memory() {
    let quickstart = example("quickstart");
    let port = free_port();
    let spawn = |args: &[&str], overrides: String| {
        Command::new(&quickstart)
            .args(args)
            .env_remove("RUST_LOG")
            .env_remove("ZENOH_SESSION_CONFIG_URI")
            .env_remove("ZENOH_ROUTER_CONFIG_URI")
            .env("ZENOH_CONFIG_OVERRIDE", overrides)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let mut router = spawn(
        &["router"],
        format!(r#"listen/endpoints=["tcp/127.0.0.1:{port}"]"#),
    );
    // The nodes start once the router runs, as a user starts them.
    let mut router_said = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(router.stdout.take().unwrap()),
        &mut router_said,
    )
    .unwrap();
    let node = || format!(r#"connect/endpoints=["tcp/127.0.0.1:{port}"]"#);
    let talker = spawn(&["talk", "16"], node());
    let listener = spawn(&["listen", "3"], node());

    // A tool at the router sees both nodes, as `shm-ros2 node list` does.
    let mut config = shm_runtime::rmw::config::default_session_config();
    config
        .insert_json5("connect/endpoints", &format!(r#"["tcp/127.0.0.1:{port}"]"#))
        .unwrap();
    let session = zenoh::Wait::wait(zenoh::open(config)).unwrap();
    let graph = shm_runtime::graph::GraphCache::of(&session, 0).unwrap();
    let both = graph.wait_until(Duration::from_secs(20), |g| {
        g.contains_node("/talk") && g.contains_node("/listen")
    });
    let nodes = graph.read().nodes();

    let (heard_ok, heard, listener_log) = finish(listener, Duration::from_secs(30));
    let (talked_ok, said, talker_log) = finish(talker, Duration::from_secs(30));
    let (_, _, router_log) = finish(router, Duration::ZERO);
    assert!(both, "the graph at the router holds {nodes:?}");
    assert!(
        router_said.starts_with("router running"),
        "router: {router_said}{router_log}"
    );
    assert_eq!(warnings(&router_log), Vec::<&str>::new(), "router");
    assert!(heard_ok, "listener: {heard}{listener_log}");
    assert!(talked_ok, "talker: {said}{talker_log}");
    assert_eq!(said.lines().count(), 16);
    // Quiet when it works, at the default log level (also as an ordinary
    // user, where Zenoh cannot raise its watchdog's priority).
    assert_eq!(warnings(&talker_log), Vec::<&str>::new(), "talker");
    assert_eq!(warnings(&listener_log), Vec::<&str>::new(), "listener");
    // Every message goes through shared memory, except one published just as
    // the listener appeared, before the talker had its answer to whether the
    // listener maps its pool: that one goes from the heap, and says so.
    let from_heap: Vec<&str> = said
        .lines()
        .filter(|line| !line.ends_with("4344 bytes as Shm"))
        .collect();
    assert!(
        from_heap.len() <= 1
            && from_heap
                .iter()
                .all(|l| l.ends_with("4344 bytes as ReceiverPending")),
        "{said}"
    );
    let received: Vec<_> = heard.lines().collect();
    assert_eq!(received.len(), 3, "{heard}");
    for line in received {
        assert!(
            line.starts_with("received #") && line.contains("1080 ranges from \"laser\""),
            "{line}"
        );
        if line.ends_with("in shared memory: false") {
            let seq = line["received #".len()..].split(':').next().unwrap();
            let sent = format!("sent     #{seq}: 4344 bytes as ReceiverPending");
            assert!(from_heap.contains(&sent.as_str()), "{line}\n{said}");
        } else {
            assert!(line.ends_with("in shared memory: true"), "{line}");
        }
    }
}

/// `pointcloud_shm`, the README's main command: the user-managed field and the
/// automatic path go through shared memory, the publisher without shared
/// memory does not (Zenoh's implicit copy into a pool of its own is off).
#[test]
fn the_main_example_sends_each_pattern_where_it_says() {
    let run = Command::new(example("pointcloud_shm"))
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let out = String::from_utf8(run.stdout).unwrap();
    assert!(run.status.success(), "{out}");
    let log = String::from_utf8_lossy(&run.stderr);
    assert_eq!(warnings(&log), Vec::<&str>::new());
    let line = |prefix: &str| {
        out.lines()
            .find(|line| line.starts_with(prefix))
            .unwrap_or_else(|| panic!("no line {prefix:?} in {out}"))
    };
    let spliced = line("1. user-managed SHM field");
    assert!(
        spliced.contains("sent as Spliced") && spliced.contains("1048576 B in shared memory"),
        "{spliced}"
    );
    let automatic = line("2. automatic threshold");
    assert!(
        automatic.contains("sent as Shm") && automatic.contains("one shared-memory buffer"),
        "{automatic}"
    );
    let heap = line("3. publisher without_shm()");
    assert!(
        heap.contains("sent as Heap") && heap.contains("heap fragments"),
        "{heap}"
    );
    assert!(
        out.contains("40 of 40 messages above the threshold went through shared memory"),
        "{out}"
    );
}
