//! `shm-ros2 interface …`: ros2interface's `list` and `show` for the standard
//! interfaces this binary was built with.

use std::io::Write;

use clap::Subcommand;
use shm_runtime::rmw::Distro;

use crate::types::{self, Kind};
use crate::Error;

#[derive(Debug, Subcommand)]
pub(crate) enum InterfaceCommand {
    /// List all interface types available.
    List,
    /// Output the interface definition.
    Show {
        /// An interface (e.g. 'std_msgs/msg/String').
        #[arg(value_name = "TYPE")]
        type_name: String,
        /// Show all comments, including for nested interface definitions.
        #[arg(long, conflicts_with = "no_comments")]
        all_comments: bool,
        /// Show no comments or whitespace.
        #[arg(long)]
        no_comments: bool,
    },
}

pub(crate) fn run(command: InterfaceCommand, distro: Distro) -> Result<(), Error> {
    let mut out = std::io::stdout().lock();
    match command {
        InterfaceCommand::List => {
            for (title, kind, namespace) in [
                ("Messages", Kind::Message, "/msg/"),
                ("Services", Kind::Service, "/srv/"),
                ("Actions", Kind::Action, "/action/"),
            ] {
                writeln!(out, "{title}:")?;
                // Interface files only: not the types derived from services
                // and actions.
                for (name, _) in types::standard()
                    .iter()
                    .filter(|(name, known)| known.kind == kind && name.contains(namespace))
                {
                    writeln!(out, "    {name}")?;
                }
            }
            Ok(())
        }
        InterfaceCommand::Show {
            type_name,
            all_comments,
            no_comments,
        } => {
            let mut text = String::new();
            show(distro, &type_name, !no_comments, all_comments, 0, &mut text)?;
            out.write_all(text.as_bytes())?;
            Ok(())
        }
    }
}

/// The interface file of a standard type, as released for `distro`.
fn source(distro: Distro, type_name: &str) -> Result<String, Error> {
    let (_, description) =
        shm_runtime::types::standard_description(type_name, distro).ok_or_else(|| {
            format!("Unknown interface '{type_name}': not a standard interface this binary knows")
        })?;
    let text = description
        .sources()
        .find(|(name, _, _)| *name == type_name)
        .map(|(_, _, text)| text.into_owned())
        .unwrap_or_default();
    Ok(text)
}

/// ros2interface's `show`: each line, and under each field of a nested type
/// that type's lines, one tab further in (without comments or blank lines
/// unless `nested_comments`).
fn show(
    distro: Distro,
    type_name: &str,
    comments: bool,
    nested_comments: bool,
    indent: usize,
    out: &mut String,
) -> Result<(), Error> {
    let (package, _) = type_name.split_once('/').ok_or_else(|| {
        format!("Invalid name '{type_name}'. Expected three parts separated by '/'")
    })?;
    let text = source(distro, type_name)?;
    // Every line of the file, a blank last one too (`lines` would drop it);
    // none of an empty one.
    let lines = text.split('\n').filter(|_| !text.is_empty());
    for line in lines {
        let line = line.trim_end();
        let code = strip_comment(line);
        let is_comment_or_blank = code.trim().is_empty();
        if !comments && is_comment_or_blank {
            continue;
        }
        let shown = if comments { line } else { code.trim() };
        if shown.is_empty() {
            out.push('\n');
        } else {
            out.push_str(&"\t".repeat(indent));
            out.push_str(shown);
            out.push('\n');
        }
        if let Some(nested) = nested_type(package, code) {
            show(
                distro,
                &nested,
                nested_comments,
                nested_comments,
                indent + 1,
                out,
            )?;
        }
    }
    Ok(())
}

/// A line without its comment (`#` outside quotes).
fn strip_comment(line: &str) -> &str {
    let mut quote = None;
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '\'' | '"') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '#') => return &line[..i],
            _ => {}
        }
    }
    line
}

/// The nested message type a field line declares, as `pkg/msg/Name`.
fn nested_type(package: &str, code: &str) -> Option<String> {
    let mut words = code.split_whitespace();
    let ty = words.next()?;
    let name = words.next()?;
    // A constant (`int32 X=1`) is not a field.
    if name.contains('=') || words.next().is_some_and(|w| w.starts_with('=')) {
        return None;
    }
    let base = ty.split(['[', '<']).next()?;
    const PRIMITIVES: [&str; 17] = [
        "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
        "uint32", "int64", "uint64", "string", "wstring", "time", "duration",
    ];
    if PRIMITIVES.contains(&base) || base == "---" {
        return None;
    }
    Some(match base.split_once('/') {
        Some((pkg, name)) => format!("{pkg}/msg/{name}"),
        None if base == "Header" => "std_msgs/msg/Header".to_owned(),
        None => format!("{package}/msg/{base}"),
    })
}
