//! A secured deployment as ROS users build one for rmw_zenoh: `shm-ros2
//! router` (rmw_zenohd's configuration) listening on TLS with mutual TLS,
//! QUIC and a Unix socket, user/password authentication, and an
//! access-control policy that allows one topic tree to one user. Certificates
//! are made in the test. A `RosNode` publisher, `shm-ros2 topic echo` and
//! `bag record` join it through configuration files, as rmw_zenoh_cpp's
//! nodes do (`ZENOH_SESSION_CONFIG_URI`); wrong credentials and a denied
//! topic are told apart from a working system, and nothing hangs.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rcgen::{BasicConstraints, CertificateParams, IsCa, Issuer, KeyPair};
use shm_cdr::msgs::std_msgs::String as RosString;
use shm_runtime::{testing, RosNode};
use zenoh::Wait;

/// The certificate authority, the router's and a client's certificates and
/// keys, as PEM files in `dir`.
fn certificates(dir: &Path) {
    let mut ca = CertificateParams::new(Vec::<String>::new()).unwrap();
    ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    let ca_key = KeyPair::generate().unwrap();
    let ca_cert = ca.self_signed(&ca_key).unwrap();
    std::fs::write(dir.join("ca.pem"), ca_cert.pem()).unwrap();
    let issuer = Issuer::new(ca, ca_key);
    for (name, hosts) in [
        (
            "router",
            vec!["localhost".to_owned(), "127.0.0.1".to_owned()],
        ),
        ("client", vec!["client.localhost".to_owned()]),
    ] {
        let key = KeyPair::generate().unwrap();
        let cert = CertificateParams::new(hosts)
            .unwrap()
            .signed_by(&key, &issuer)
            .unwrap();
        std::fs::write(dir.join(format!("{name}.pem")), cert.pem()).unwrap();
        std::fs::write(dir.join(format!("{name}.key")), key.serialize_pem()).unwrap();
    }
}

/// The TLS settings of a configuration, with `who`'s certificate and key.
fn tls(dir: &Path, who: &str) -> String {
    let path = |name: &str| dir.join(name).display().to_string();
    format!(
        r#"tls: {{
            root_ca_certificate: "{ca}",
            listen_private_key: "{key}",
            listen_certificate: "{cert}",
            connect_private_key: "{key}",
            connect_certificate: "{cert}",
            enable_mtls: true,
            verify_name_on_connect: false,
        }}"#,
        ca = path("ca.pem"),
        key = path(&format!("{who}.key")),
        cert = path(&format!("{who}.pem")),
    )
}

struct Deployment {
    dir: PathBuf,
    router: Child,
    tls: String,
    quic: String,
    unix: String,
}

impl Drop for Deployment {
    fn drop(&mut self) {
        let _ = self.router.kill();
        let _ = self.router.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The router, on TLS, QUIC and a Unix socket, with users `alice` (allowed
/// `/allowed/**` and the graph) and `mallory` (the graph only), as
/// `shm-ros2 router` started with `ZENOH_ROUTER_CONFIG_URI`.
fn deploy() -> Deployment {
    let dir = std::env::temp_dir().join(format!("shm_cli_secure_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    certificates(&dir);
    std::fs::write(dir.join("users.txt"), "alice:wonderland\nmallory:sneaky\n").unwrap();
    let tls_endpoint = format!("tls/127.0.0.1:{}", testing::free_port().unwrap());
    let quic_endpoint = format!("quic/127.0.0.1:{}", testing::free_port().unwrap());
    let unix_endpoint = format!("unixsock-stream/{}", dir.join("router.sock").display());
    let config = format!(
        r#"{{
        listen: {{ endpoints: ["{tls_endpoint}", "{quic_endpoint}", "{unix_endpoint}"] }},
        transport: {{
            link: {{ {tls} }},
            auth: {{ usrpwd: {{ user: "router", password: "routerpw", dictionary_file: "{users}" }} }},
        }},
        access_control: {{
            enabled: true,
            default_permission: "deny",
            rules: [
                {{
                    id: "graph",
                    messages: ["liveliness_token", "liveliness_query", "declare_liveliness_subscriber", "reply"],
                    flows: ["ingress", "egress"],
                    permission: "allow",
                    key_exprs: ["@ros2_lv/0/**"],
                }},
                {{
                    id: "allowed_topics",
                    messages: ["put", "declare_subscriber", "query", "declare_queryable", "reply"],
                    flows: ["ingress", "egress"],
                    permission: "allow",
                    key_exprs: ["0/allowed/**", "@shm_cdr/probe/**"],
                }},
                {{
                    id: "shm_receivers",
                    messages: ["liveliness_token", "declare_liveliness_subscriber", "liveliness_query", "reply"],
                    flows: ["ingress", "egress"],
                    permission: "allow",
                    key_exprs: ["0/allowed/**/@shm_cdr_rx/**"],
                }},
            ],
            subjects: [
                {{ id: "alice", usernames: ["alice"] }},
                {{ id: "mallory", usernames: ["mallory"] }},
            ],
            policies: [
                {{ rules: ["graph", "allowed_topics", "shm_receivers"], subjects: ["alice"] }},
                {{ rules: ["graph"], subjects: ["mallory"] }},
            ],
        }},
    }}"#,
        tls = tls(&dir, "router"),
        users = dir.join("users.txt").display(),
    );
    std::fs::write(dir.join("router.json5"), config).unwrap();
    let mut router = Command::new(env!("CARGO_BIN_EXE_shm-ros2"))
        .arg("router")
        .env("ZENOH_ROUTER_CONFIG_URI", dir.join("router.json5"))
        .env_remove("ZENOH_CONFIG_OVERRIDE")
        .env("RUST_LOG", "error")
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut said = String::new();
    BufReader::new(router.stdout.take().unwrap())
        .read_line(&mut said)
        .unwrap();
    assert!(said.contains("listening on"), "the router said {said:?}");
    Deployment {
        dir,
        router,
        tls: tls_endpoint,
        quic: quic_endpoint,
        unix: unix_endpoint,
    }
}

impl Deployment {
    /// A client session's configuration file reaching the router at
    /// `endpoint` as `user` with `password`.
    fn client_config(&self, endpoint: &str, user: &str, password: &str) -> PathBuf {
        let path = self.dir.join(format!(
            "client_{}_{user}_{password}.json5",
            endpoint.split('/').next().unwrap_or("x")
        ));
        std::fs::write(
            &path,
            format!(
                r#"{{
                mode: "client",
                connect: {{ endpoints: ["{endpoint}"] }},
                transport: {{
                    link: {{ {tls} }},
                    auth: {{ usrpwd: {{ user: "{user}", password: "{password}" }} }},
                }},
            }}"#,
                tls = tls(&self.dir, "client"),
            ),
        )
        .unwrap();
        path
    }

    /// `shm-ros2 <args>` with the session configuration `config`, as a
    /// user runs it with `ZENOH_SESSION_CONFIG_URI`.
    fn cli(&self, config: &Path, args: &[&str]) -> Command {
        self.cli_waiting(config, 5, args)
    }

    /// [`cli`](Self::cli), waiting up to `seconds` for the graph and answers.
    fn cli_waiting(&self, config: &Path, seconds: u32, args: &[&str]) -> Command {
        let mut command = Command::new(env!("CARGO_BIN_EXE_shm-ros2"));
        command
            .args(["--domain-id", "0", "--timeout", &seconds.to_string()])
            .args(args)
            .env("ZENOH_SESSION_CONFIG_URI", config)
            .env_remove("ZENOH_CONFIG_OVERRIDE")
            .env_remove("ZENOH_ROUTER_CHECK_ATTEMPTS")
            .env_remove("ROS_DISTRO")
            .env("RUST_LOG", "error");
        command
    }
}

/// Run `command` for at most `limit`; its exit status (`None`: still
/// running at the limit, then killed) and output.
fn run_for(mut command: Command, limit: Duration) -> (Option<i32>, String, String) {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let output = child.wait_with_output().unwrap();
    (
        status,
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

#[test]
fn tools_join_a_router_with_tls_authentication_and_access_control() {
    let deployment = deploy();
    // A node of this crate, as alice over mutual TLS, publishing on an
    // allowed topic and on one the policy denies.
    let config =
        zenoh::Config::from_file(deployment.client_config(&deployment.tls, "alice", "wonderland"))
            .unwrap();
    let session = zenoh::open(config).wait().unwrap();
    let node = RosNode::builder(&session, "secure_talker")
        .domain_id(0)
        .enclave("/talker_listener/talker")
        .wait()
        .unwrap();
    let allowed = node
        .declare_publisher::<RosString>("/allowed/chatter")
        .wait()
        .unwrap();
    let denied = node
        .declare_publisher::<RosString>("/denied/chatter")
        .wait()
        .unwrap();
    let alive = std::sync::Arc::new(());
    let weak = std::sync::Arc::downgrade(&alive);
    std::thread::spawn(move || {
        while weak.upgrade().is_some() {
            let message = RosString {
                data: "through the router".into(),
            };
            allowed.publish(&message).wait().unwrap();
            denied.publish(&message).wait().unwrap();
            std::thread::sleep(Duration::from_millis(50));
        }
    });

    // The same user over each transport reads the allowed topic, and the
    // graph shows the node in its enclave.
    for endpoint in [&deployment.tls, &deployment.quic, &deployment.unix] {
        let config = deployment.client_config(endpoint, "alice", "wonderland");
        let (status, out, err) = run_for(
            deployment.cli(&config, &["topic", "echo", "/allowed/chatter", "--once"]),
            Duration::from_secs(30),
        );
        assert_eq!(status, Some(0), "echo over {endpoint}: {err}");
        assert!(
            out.contains("data: through the router"),
            "over {endpoint}: {out}"
        );
    }
    let config = deployment.client_config(&deployment.tls, "alice", "wonderland");
    // The graph's first answers come through the router over TLS: on a
    // loaded machine they may take longer than the other commands' 5 s.
    let (status, out, err) = run_for(
        deployment.cli_waiting(&config, 25, &["node", "list", "-a"]),
        Duration::from_secs(30),
    );
    assert_eq!(status, Some(0), "{err}");
    assert!(out.contains("/secure_talker"), "{out}");

    // A recording over TLS.
    let bag = deployment.dir.join("bag");
    let recorder = deployment
        .cli(
            &config,
            &[
                "bag",
                "record",
                "/allowed/chatter",
                "-o",
                bag.to_str().unwrap(),
                "--no-progress",
                "--disable-keyboard-controls",
            ],
        )
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(4));
    Command::new("kill")
        .args(["-INT", &recorder.id().to_string()])
        .status()
        .unwrap();
    let output = recorder.wait_with_output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let recorded = shm_bag::Bag::open(&bag).unwrap().topics().unwrap();
    assert!(
        recorded
            .iter()
            .any(|t| t.name == "/allowed/chatter" && t.message_count > 10),
        "{recorded:?}"
    );

    // The topic the policy denies: its publisher is in the graph, nothing
    // of it reaches the subscriber, and echo says why it may be so instead
    // of waiting without a word.
    let (status, out, err) = run_for(
        deployment.cli(&config, &["topic", "echo", "/denied/chatter", "--once"]),
        Duration::from_secs(12),
    );
    assert_eq!(status, None, "echo of a denied topic ended: {out} {err}");
    assert!(!out.contains("through the router"), "{out}");
    assert!(err.contains("access-control policy"), "{err}");

    // Another user, allowed the graph only, sees the node but not its data.
    let mallory = deployment.client_config(&deployment.tls, "mallory", "sneaky");
    let (status, out, _) = run_for(
        deployment.cli(&mallory, &["topic", "echo", "/allowed/chatter", "--once"]),
        Duration::from_secs(12),
    );
    assert_eq!(status, None);
    assert!(!out.contains("through the router"), "{out}");

    // Wrong credentials: refused at once, with what to check.
    let wrong = deployment.client_config(&deployment.tls, "alice", "guess");
    let (status, _, err) = run_for(
        deployment.cli(&wrong, &["topic", "list"]),
        Duration::from_secs(30),
    );
    assert_eq!(status, Some(1), "{err}");
    assert!(err.contains("credentials"), "{err}");
    drop(alive);
}
