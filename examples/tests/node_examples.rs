//! The node examples the guide points to, run as a user would run them.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The example built next to this test (`cargo test` builds examples).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(Path::parent).unwrap();
    dir.join("examples").join(name)
}

fn run(name: &str, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(example(name))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_parameter_node_takes_its_file_and_the_command_line_and_refuses_a_value_out_of_range() {
    let (ok, out, err) = run(
        "param_node",
        &[
            "0",
            "--ros-args",
            "--params-file",
            "config/driver.yaml",
            "-p",
            "max_speed:=1.2",
        ],
    );
    assert!(ok, "{err}");
    // frame_id from `/**`, the wheels from the node's own section, max_speed from -p.
    assert!(
        out.contains("frame_id=base_link max_speed=1.2 wheels.radius=0.05 wheels.separation=0.3"),
        "{out}"
    );
    let (ok, _, err) = run("param_node", &["0", "--ros-args", "-p", "max_speed:=3.5"]);
    assert!(!ok);
    assert!(
        err.contains("max_speed") && err.contains("out of range"),
        "{err}"
    );
}

#[test]
fn the_simulated_time_node_steps_with_the_simulation() {
    let (ok, out, err) = run("sim_time_node", &[]);
    assert!(ok, "{err}");
    let steps = out
        .lines()
        .filter(|l| l.starts_with("control step"))
        .count();
    // Five simulated seconds in about one real second: a timer of one
    // simulated second fires four or five times (never once per real second).
    assert!((3..=5).contains(&steps), "{out}");
    // None fires while the simulation is paused: the step after the pause is
    // at the third simulated second at the earliest.
    let after_pause = out
        .lines()
        .skip_while(|l| !l.starts_with("paused"))
        .find(|l| l.starts_with("control step"));
    if let Some(line) = after_pause {
        let t: f64 = line
            .rsplit("t = ")
            .next()
            .unwrap()
            .trim_end_matches(" s")
            .parse()
            .unwrap();
        assert!(t >= 2.99, "{out}");
    }
}
