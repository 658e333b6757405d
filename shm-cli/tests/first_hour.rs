//! What a newcomer meets first, with the logging defaults they get: a verb
//! with nothing to talk to, the router the project ships, and the output of
//! commands that work.

use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use shm_cdr::msgs::std_msgs::String as RosString;
use shm_runtime::rmw::config;
use shm_runtime::{testing, RosNode};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(15);

/// `shm-ros2` as a user runs it: no logging or Zenoh variables set.
fn shm_ros2(port: u16) -> Command {
    shm_ros2_at(&format!("tcp/127.0.0.1:{port}"))
}

/// [`shm_ros2`] connecting to `endpoint`.
fn shm_ros2_at(endpoint: &str) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_shm-ros2"));
    command
        .args(["--connect", endpoint])
        .env_remove("RUST_LOG")
        .env_remove("NO_COLOR")
        .env_remove("ZENOH_SESSION_CONFIG_URI")
        .env_remove("ZENOH_CONFIG_OVERRIDE")
        .env_remove("ZENOH_ROUTER_CHECK_ATTEMPTS")
        .env_remove("ROS_DISTRO")
        .env_remove("ROS_DOMAIN_ID");
    command
}

/// A Zenoh log line at warning level or above, as the default format prints it.
fn warnings(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.contains(" WARN ") || l.contains(" ERROR "))
        .collect()
}

#[test]
fn with_nothing_to_reach_a_query_exits_1_and_says_what_to_start() {
    let port = testing::free_port().unwrap();
    for verb in [
        &["topic", "list"][..],
        &["node", "list"],
        &["param", "list", "/robot/driver"],
    ] {
        let out = shm_ros2(port).args(verb).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{verb:?}: {stderr}");
        assert!(out.stdout.is_empty(), "{verb:?} printed a result");
        assert!(
            stderr.contains(&format!(
                "No Zenoh router or peer reached at [\"tcp/127.0.0.1:{port}\"]"
            )) && stderr.contains("shm-ros2 router"),
            "{verb:?}: {stderr}"
        );
        assert_eq!(warnings(&stderr), Vec::<&str>::new(), "{verb:?}");
        // Not a terminal: no colour codes.
        assert!(!stderr.contains('\u{1b}'), "{verb:?}: {stderr:?}");
    }
}

/// `shm-ros2 router`, stopped when dropped.
struct Router(Child);

impl Router {
    fn start(port: u16) -> Self {
        let child = shm_ros2(port)
            .args(["router", "--listen", &format!("tcp/127.0.0.1:{port}")])
            .stdout(Stdio::null())
            .spawn()
            .unwrap();
        let deadline = Instant::now() + TIMEOUT;
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(Instant::now() < deadline, "the router never listened");
            std::thread::sleep(Duration::from_millis(20));
        }
        Self(child)
    }
}

impl Drop for Router {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_router_lets_programs_that_know_only_it_find_each_other() {
    let port = testing::free_port().unwrap();
    let _router = Router::start(port);
    // rmw_zenoh_cpp's session defaults, pointed at the router only.
    let session = || {
        let mut c = config::default_session_config();
        config::apply_override(
            &mut c,
            &format!("connect/endpoints=[\"tcp/127.0.0.1:{port}\"]"),
        )
        .unwrap();
        zenoh::open(c).wait().unwrap()
    };
    let (a, b) = (session(), session());
    let talker = RosNode::builder(&a, "talker").wait().unwrap();
    let listener = RosNode::builder(&b, "listener").wait().unwrap();
    let publisher = talker
        .declare_publisher::<RosString>("chatter")
        .wait()
        .unwrap();
    let subscriber = listener
        .declare_subscriber::<RosString>("chatter")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    publisher
        .publish(&RosString {
            data: "hello".into(),
        })
        .wait()
        .unwrap();
    let sample = subscriber.recv_timeout(TIMEOUT).unwrap().unwrap();
    assert_eq!(sample.decode::<RosString>().unwrap().data, "hello");

    // Asked again and again: each run sees both at once.
    for _ in 0..5 {
        let out = shm_ros2(port).args(["node", "list"]).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            stdout.lines().any(|l| l == "/talker") && stdout.lines().any(|l| l == "/listener"),
            "{stdout}"
        );
    }
    let out = shm_ros2(port).args(["node", "list"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stdout.lines().any(|l| l == "/talker") && stdout.lines().any(|l| l == "/listener"),
        "{stdout}"
    );
    // A node that is not there: an error, as ros2cli gives it.
    let out = shm_ros2(port)
        .args(["--timeout", "1", "param", "list", "/nobody"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "Node not found"
    );

    let out = shm_ros2(port).args(["node", "list"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // A working command prints nothing else at the default log level.
    assert_eq!(warnings(&stderr), Vec::<&str>::new());
    assert_eq!(stderr, "", "a working command wrote to stderr");
}

/// A router that refuses the login, or that speaks TCP to a `tls/`
/// endpoint: one line in the project's words that names the cause, and no
/// Zenoh ERROR lines.
#[test]
fn a_router_that_refuses_the_session_is_named_as_the_cause() {
    let port = testing::free_port().unwrap();
    let dir = std::env::temp_dir().join(format!("shm_cli_login_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let users = dir.join("users.txt");
    std::fs::write(&users, "alice:alicepw\n").unwrap();
    let mut router = config::default_router_config();
    for (key, value) in [
        ("listen/endpoints", format!(r#"["tcp/127.0.0.1:{port}"]"#)),
        (
            "transport/auth/usrpwd",
            format!(
                r#"{{ user: "router", password: "routerpw", dictionary_file: "{}" }}"#,
                users.display()
            ),
        ),
    ] {
        router.insert_json5(key, &value).unwrap();
    }
    let _router = zenoh::open(router).wait().unwrap();

    let wrong = dir.join("wrong.json5");
    std::fs::write(
        &wrong,
        r#"{ transport: { auth: { usrpwd: { user: "alice", password: "wrong" } } } }"#,
    )
    .unwrap();
    // One line, exit status 1, naming the cause.
    let says = |mut command: Command, cause: &str| {
        let out = command.args(["topic", "list"]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(cause), "{stderr}");
    };
    let mut login = shm_ros2(port);
    login.args(["--zenoh-config", wrong.to_str().unwrap()]);
    says(
        login,
        &format!(
            "a process listens at 127.0.0.1:{port} and closed the session: it refused the user \
             and password"
        ),
    );
    says(
        shm_ros2_at(&format!("tls/127.0.0.1:{port}")),
        "no TLS session opened with it: it may listen with tcp/ where tls/ was given",
    );
    let _ = std::fs::remove_dir_all(&dir);
}
