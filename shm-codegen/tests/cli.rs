//! `shm-codegen` run on a user's own package, as the guide shows it.

use std::path::PathBuf;
use std::process::Command;

fn robot_interfaces() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/interfaces/robot_interfaces")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shm-codegen-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn a_users_package_is_generated_without_features_and_counted_in_english() {
    let out = scratch("user");
    let run = Command::new(env!("CARGO_BIN_EXE_shm-codegen"))
        .arg("--out-dir")
        .arg(&out)
        .arg(robot_interfaces())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    // (Before it, a note that rustfmt is missing, where it is.)
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("shm-codegen: 1 package, ")),
        "{stderr}"
    );
    assert!(!stderr.contains("usage"), "{stderr}");

    let module = std::fs::read_to_string(out.join("mod.rs")).unwrap();
    assert!(!module.contains("Standard"), "{module}");
    // No feature the user's Cargo.toml does not have.
    assert!(!module.contains("cfg(feature"), "{module}");
    assert!(module.contains("\npub mod robot_interfaces;"), "{module}");

    let package = std::fs::read_to_string(out.join("robot_interfaces.rs")).unwrap();
    assert!(!package.contains(" 1 messages") && !package.contains(" 1 services"));
    // Pub items a binary crate does not use are not warned about.
    assert!(package.contains("#[allow(non_camel_case_types, dead_code, clippy::all)]"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_bad_interface_file_is_reported_without_the_usage() {
    let root = scratch("bad");
    let package = root.join("bad_pkg");
    std::fs::create_dir_all(package.join("msg")).unwrap();
    std::fs::write(
        package.join("msg/Broken.msg"),
        "float64 x\nnot a field line at all\n",
    )
    .unwrap();
    let out = scratch("bad-out");
    let run = Command::new(env!("CARGO_BIN_EXE_shm-codegen"))
        .arg("--out-dir")
        .arg(&out)
        .arg(&package)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("Broken.msg"), "{stderr}");
    assert!(!stderr.contains("usage:"), "{stderr}");

    // A mistake in the command line does get the usage.
    let run = Command::new(env!("CARGO_BIN_EXE_shm-codegen"))
        .arg("--no-such-flag")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("unknown option --no-such-flag") && stderr.contains("usage:"));
    let _ = std::fs::remove_dir_all(&root);
    let _ = std::fs::remove_dir_all(&out);
}
