//! The README's quick start: its code is `examples/quickstart.rs`, word for
//! word, and a talker and a listener started from it exchange messages
//! through shared memory in two processes.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

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

#[test]
fn a_talker_and_a_listener_exchange_the_users_struct_through_shared_memory() {
    let quickstart = example("quickstart");
    let talker = Command::new(&quickstart)
        .args(["talk", "16"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let listener = Command::new(&quickstart)
        .args(["listen", "3"])
        .output()
        .unwrap();
    let talked = talker.wait_with_output().unwrap();
    let heard = String::from_utf8(listener.stdout).unwrap();
    let said = String::from_utf8(talked.stdout).unwrap();
    assert!(listener.status.success(), "listener: {heard}");
    assert!(talked.status.success(), "talker: {said}");
    let received: Vec<_> = heard.lines().collect();
    assert_eq!(received.len(), 3, "{heard}");
    for line in received {
        assert!(
            line.starts_with("received #")
                && line.ends_with("1080 ranges from \"laser\", in shared memory: true"),
            "{line}"
        );
    }
    assert_eq!(said.lines().count(), 16);
    assert!(
        said.lines().all(|line| line.ends_with("4344 bytes as Shm")),
        "{said}"
    );
}
