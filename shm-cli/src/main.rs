//! `shm-ros2`: the ROS 2 command line for systems on rmw_zenoh, with no ROS
//! install. The commands, arguments and output formats are ros2cli's
//! (`ros2 topic echo`, `ros2 param set`, …); types the binary was not built
//! with are asked of the publishing node's `~/get_type_description` and read
//! at run time.

mod action;
mod bag;
mod context;
mod interface;
mod keyboard;
mod node;
mod param;
mod python;
mod router;
mod service;
mod topic;
mod types;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// A ROS 2 command line for rmw_zenoh systems, with no ROS install.
#[derive(Debug, Parser)]
#[command(name = "shm-ros2", version, about)]
struct Cli {
    #[command(flatten)]
    connection: context::Connection,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Topics: list, info, type, echo, hz, bw, pub.
    #[command(subcommand)]
    Topic(topic::TopicCommand),
    /// Nodes: list, info.
    #[command(subcommand)]
    Node(node::NodeCommand),
    /// Services: list, type, call.
    #[command(subcommand)]
    Service(service::ServiceCommand),
    /// Actions: list, info, send_goal.
    #[command(subcommand)]
    Action(action::ActionCommand),
    /// Parameters: list, get, set, dump, load.
    #[command(subcommand)]
    Param(param::ParamCommand),
    /// Interfaces: list, show.
    #[command(subcommand)]
    Interface(interface::InterfaceCommand),
    /// Recordings: record, play, info, convert, reindex (MCAP and sqlite3,
    /// as rosbag2 writes them).
    #[command(subcommand)]
    Bag(bag::BagCommand),
    /// Run a Zenoh router configured as rmw_zenoh_cpp's `rmw_zenohd`, for
    /// systems without ROS.
    Router(router::RouterArgs),
    /// Print the shell completion script for bash, zsh, fish, elvish or
    /// PowerShell (bash: `source <(shm-ros2 completions bash)`).
    Completions {
        /// The shell to complete in.
        shell: clap_complete::Shell,
    },
}

/// A failure to report: the message says what happened and what to do.
pub(crate) type Error = Box<dyn std::error::Error + Send + Sync>;

/// A flag set when Ctrl-C, SIGTERM (`docker stop`, systemd, launch) or
/// SIGHUP (the terminal closed) arrives, which then no longer ends the
/// process: for verbs that finish their work first. A second signal ends it
/// at once, exit status 130, as a second Ctrl-C does for `ros2 bag record`.
pub(crate) fn interrupted() -> Result<std::sync::Arc<std::sync::atomic::AtomicBool>, Error> {
    use std::sync::atomic::{AtomicBool, Ordering};
    let flag = std::sync::Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    ctrlc::set_handler(move || {
        if set.swap(true, Ordering::Relaxed) {
            std::process::exit(130);
        }
    })
    .map_err(|e| format!("cannot catch Ctrl-C, SIGTERM and SIGHUP: {e}"))?;
    Ok(flag)
}

/// `n` and the noun, plural unless `n` is 1: "1 topic", "3 topics".
pub(crate) fn counted(n: impl Into<u64>, noun: &str) -> String {
    match n.into() {
        1 => format!("1 {noun}"),
        n => format!("{n} {noun}s"),
    }
}

/// `--version` with the Zenoh line, its shared-memory protocol and the ROS 2
/// distributions whose nodes share memory with this build.
fn long_version() -> String {
    let sharing: Vec<&str> = shm_runtime::rmw::DISTRIBUTIONS
        .iter()
        .filter(|release| release.shares_memory_with_this_build())
        .map(|release| release.name)
        .collect();
    format!(
        "{}\nZenoh {} (shared-memory protocol {})\nshared memory with rmw_zenoh_cpp nodes of: {}",
        env!("CARGO_PKG_VERSION"),
        shm_runtime::ZenohLine::BUILT,
        shm_runtime::ZenohLine::BUILT_SHM_PROTOCOL,
        if sharing.is_empty() {
            "none (their Zenoh speaks another shared-memory protocol)".to_string()
        } else {
            sharing.join(", ")
        }
    )
}

fn parse_cli() -> Cli {
    use clap::{CommandFactory, FromArgMatches};
    let matches = Cli::command().long_version(long_version()).get_matches();
    match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(error) => error.exit(),
    }
}

fn main() -> ExitCode {
    shm_runtime::init_logging();
    let cli = parse_cli();
    let result = match cli.command {
        Command::Interface(command) => interface::run(command, cli.connection.distro()),
        Command::Router(args) => router::run(&args),
        Command::Completions { shell } => {
            use clap::CommandFactory;
            use std::io::Write;
            // Into memory first: clap_complete panics on a failed write (a
            // closed pipe), which is an ordinary error here.
            let mut script = Vec::new();
            clap_complete::generate(shell, &mut Cli::command(), "shm-ros2", &mut script);
            if shell == clap_complete::Shell::Bash {
                // clap_complete spells the hyphenated name two ways in bash,
                // so nothing past the first word completes
                // (clap-rs/clap#6421): one spelling for both.
                let text =
                    String::from_utf8_lossy(&script).replace("shm__subcmd__ros2", "shm__ros2");
                script = text.into_bytes();
            }
            std::io::stdout().write_all(&script).map_err(Error::from)
        }
        Command::Bag(
            command @ (bag::BagCommand::Info { .. }
            | bag::BagCommand::Reindex { .. }
            | bag::BagCommand::Convert(_)),
        ) => bag::run(None, command),
        command => match context::Context::open(&cli.connection) {
            Ok(context) => match command {
                // Verbs that wait for what they read or serve may start
                // before the system; the others ask it something now.
                Command::Topic(c) if c.waits() => {
                    context.warn_unreached();
                    topic::run(&context, c)
                }
                Command::Bag(c) => {
                    context.warn_unreached();
                    bag::run(Some(&context), c)
                }
                command => {
                    if let Err(e) = context.require_reached() {
                        // Nothing was reached, so nothing waits to be sent:
                        // end without closing the session, whose close waits
                        // (and logs an error) on the links still being tried.
                        eprintln!("{e}");
                        std::process::exit(1);
                    }
                    match command {
                        Command::Topic(c) => topic::run(&context, c),
                        Command::Node(c) => node::run(&context, c),
                        Command::Service(c) => service::run(&context, c),
                        Command::Param(c) => param::run(&context, c),
                        Command::Action(c) => action::run(&context, c),
                        Command::Bag(_)
                        | Command::Interface(_)
                        | Command::Router(_)
                        | Command::Completions { .. } => {
                            unreachable!("handled above")
                        }
                    }
                }
            },
            Err(e) => Err(e),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the output went away (`| head`): it has what it
        // wanted, and nothing is left to say.
        Err(e) if is_broken_pipe(e.as_ref()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

/// Whether `error`, or one of its causes, is a write to a closed pipe.
fn is_broken_pipe(error: &(dyn std::error::Error + 'static)) -> bool {
    let mut cause = Some(error);
    while let Some(e) = cause {
        if e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        {
            return true;
        }
        cause = e.source();
    }
    false
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn counts_take_the_plural_unless_one() {
        assert_eq!(super::counted(1u64, "topic"), "1 topic");
        assert_eq!(super::counted(0u64, "topic"), "0 topics");
        assert_eq!(super::counted(20u64, "message"), "20 messages");
    }

    /// Clap's own checks of every verb's arguments (unique short names, …),
    /// which otherwise run only when a verb is used in a debug build.
    #[test]
    fn every_verbs_arguments_are_consistent() {
        super::Cli::command().debug_assert();
    }
}
