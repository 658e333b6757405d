//! `shm-codegen`: generate Rust modules from ROS 2 interface packages.
//!
//! ```text
//! shm-codegen [--crate-path PATH] [--extern-root PATH] [--arbitrary] [--no-borrowed]
//!             [--shm-bytes TYPE [--shm-forms-only]] [--features CARGO_TOML
//!             [--forward-features CRATE]] [--registry FILE]
//!             [--distro-sources FILE (--sources-of DISTRO=DIR)...] --out-dir DIR PKG_DIR...
//! ```
//!
//! Writes `DIR/<pkg>.rs` for each package and `DIR/mod.rs` declaring them. With
//! `--features`, each is behind a Cargo feature named after the package, and the
//! block between `# BEGIN shm-codegen features` and `# END shm-codegen features`
//! in that Cargo.toml is rewritten: one feature per package, enabling the
//! packages it references. With `--registry`, also writes FILE: a `for_each_interface!`
//! macro that lists every generated type under `::shm_cdr::msgs`, for checks
//! that cover the whole set. `--shm-bytes TYPE` adds a `<Name>Shm` form of each
//! message with byte sequences of its own; with `--shm-forms-only` those forms
//! are all that is written (packages without any are left out), and
//! `--forward-features CRATE` makes each package's feature enable `CRATE/<pkg>`.
//! With `--distro-sources`, also writes FILE: the interface files that the
//! packages in each `--sources-of` DIR (one folder per package, as a
//! distribution releases them) word differently from PKG_DIR's, with the same
//! definitions (a definition that differs is an error).
//! Output goes through `rustfmt` when it is installed.
//! `shm-codegen/generate-standard-set.sh` runs it for `shm_cdr::msgs` and
//! `shm_runtime::msgs`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use shm_codegen::{rust, Builder, GENERATED_MARKER};

const BEGIN: &str = "# BEGIN shm-codegen features";
const END: &str = "# END shm-codegen features";

struct Args {
    builder: Builder,
    out_dir: PathBuf,
    features: Option<PathBuf>,
    registry: Option<PathBuf>,
    forward_features: Option<String>,
    distro_sources: Option<PathBuf>,
    sources_of: Vec<(String, PathBuf)>,
    options: rust::Options,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let mut options = rust::Options::default();
    let mut builder = Builder::new();
    let mut out_dir = None;
    let mut features = None;
    let mut registry = None;
    let mut forward_features = None;
    let mut distro_sources = None;
    let mut sources_of = Vec::new();
    let mut packages = 0;
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--crate-path" => options.crate_path = value("--crate-path")?,
            "--extern-root" => options.extern_root = value("--extern-root")?,
            "--arbitrary" => options.arbitrary = true,
            "--no-borrowed" => options.borrowed = false,
            "--shm-bytes" => options.shm_bytes = Some(value("--shm-bytes")?),
            "--shm-forms-only" => options.shm_forms_only = true,
            "--forward-features" => forward_features = Some(value("--forward-features")?),
            "--out-dir" => out_dir = Some(PathBuf::from(value("--out-dir")?)),
            "--features" => features = Some(PathBuf::from(value("--features")?)),
            "--registry" => registry = Some(PathBuf::from(value("--registry")?)),
            "--distro-sources" => {
                distro_sources = Some(PathBuf::from(value("--distro-sources")?));
            }
            "--sources-of" => {
                let given = value("--sources-of")?;
                let (distro, dir) = given
                    .split_once('=')
                    .ok_or(format!("--sources-of {given}: write DISTRO=DIR"))?;
                sources_of.push((distro.to_owned(), PathBuf::from(dir)));
            }
            "-h" | "--help" => return Err(String::new()),
            flag if flag.starts_with("--") => return Err(format!("unknown option {flag}")),
            dir => {
                builder = builder.package(dir);
                packages += 1;
            }
        }
    }
    let out_dir = out_dir.ok_or("--out-dir is required")?;
    if packages == 0 {
        return Err("no package folders given".into());
    }
    if sources_of.is_empty() != distro_sources.is_none() {
        return Err("--distro-sources FILE and --sources-of DISTRO=DIR go together".into());
    }
    if options.shm_forms_only && options.shm_bytes.is_none() {
        return Err("--shm-forms-only needs --shm-bytes TYPE".into());
    }
    builder = builder
        .crate_path(&options.crate_path)
        .extern_root(&options.extern_root)
        .arbitrary(options.arbitrary)
        .borrowed(options.borrowed);
    Ok(Args {
        builder,
        out_dir,
        features,
        registry,
        forward_features,
        distro_sources,
        sources_of,
        options,
    })
}

const USAGE: &str = "usage: shm-codegen [--crate-path PATH] [--extern-root PATH] [--arbitrary] [--no-borrowed] [--shm-bytes TYPE [--shm-forms-only]] [--features CARGO_TOML [--forward-features CRATE]] [--registry FILE] [--distro-sources FILE (--sources-of DISTRO=DIR)...] --out-dir DIR PKG_DIR...";

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(args) => args,
        // The usage goes with a mistake in the command line (or --help) only.
        Err(e) => {
            if e.is_empty() {
                println!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            eprintln!("shm-codegen: {e}\n{USAGE}");
            return ExitCode::FAILURE;
        }
    };
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("shm-codegen: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The table of what each distribution words differently, for the packages
/// it releases.
fn distro_sources(
    loaded: &[shm_codegen::ast::Package],
    sources_of: &[(String, PathBuf)],
) -> Result<String, String> {
    let mut rows = Vec::new();
    for (distro, dir) in sources_of {
        for ours in loaded {
            let theirs_dir = dir.join(&ours.name);
            if !theirs_dir.is_dir() {
                continue;
            }
            let theirs = shm_codegen::load_package(&theirs_dir).map_err(|e| e.to_string())?;
            let reworded = shm_codegen::ast::reworded_sources(ours, &theirs)
                .map_err(|e| format!("{distro}: {e}"))?;
            rows.extend(reworded.into_iter().map(|r| (distro.clone(), r)));
        }
    }
    let distros: Vec<&str> = sources_of.iter().map(|(d, _)| d.as_str()).collect();
    Ok(format!(
        "{GENERATED_MARKER}\n//! The interface files of the standard set as released for {}, where\n//! their text differs from the one `msgs` carries (comments only: the same\n//! definitions, so the same bytes and hashes). Written by\n//! `shm-codegen/generate-standard-set.sh` from that release's packages.\n\n{}",
        distros.join(", "),
        rust::distro_sources(&rows)
    ))
}

fn run(args: Args) -> Result<(), String> {
    let loaded = args.builder.load().map_err(|e| e.to_string())?;
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| format!("{}: {e}", args.out_dir.display()))?;
    let (packages, sources): (Vec<_>, Vec<_>) = loaded
        .iter()
        .zip(rust::generate(&loaded, &args.options))
        .filter(|(_, source)| !source.body.is_empty())
        .unzip();
    let intro = match (args.options.shm_forms_only, args.features.is_some()) {
        (true, _) => "Shared-memory forms of the ROS 2 messages that carry byte sequences,\n//! generated by shm-codegen from the interface packages' own `.msg`, `.srv` and\n//! `.action` files. One Cargo feature per package, named after it.",
        (false, true) => "ROS 2 interfaces, generated by shm-codegen from the interface packages'\n//! own `.msg`, `.srv` and `.action` files. One Cargo feature per package,\n//! named after it; enabling one enables the packages it references.",
        (false, false) => "ROS 2 interfaces, generated by shm-codegen from the interface packages'\n//! own `.msg`, `.srv` and `.action` files.",
    };
    // Behind a feature per package only where the features are written.
    let gated = args.features.is_some();
    let mut module = match gated {
        true => format!("{GENERATED_MARKER}\n//! {intro}\n//!\n//! | package | feature | contents |\n//! |---|---|---|\n"),
        false => format!("{GENERATED_MARKER}\n//! {intro}\n//!\n//! | package | contents |\n//! |---|---|\n"),
    };
    for (package, source) in packages.iter().zip(&sources) {
        let counts = source
            .summary
            .split_once(": ")
            .map_or("", |(_, c)| c)
            .trim_end_matches('.');
        module.push_str(&match gated {
            true => format!("//! | `{0}` | `{0}` | {counts} |\n", package.name),
            false => format!("//! | `{}` | {counts} |\n", package.name),
        });
    }
    for source in &sources {
        module.push_str(&match gated {
            true => format!("\n#[cfg(feature = \"{0}\")]\npub mod {0};", source.name),
            false => format!("\npub mod {};", source.name),
        });
        let text = format!(
            "{GENERATED_MARKER}\n//! {}\n\n{}",
            source.summary, source.body
        );
        write(&args.out_dir.join(format!("{}.rs", source.name)), &text)?;
    }
    module.push('\n');
    write(&args.out_dir.join("mod.rs"), &module)?;
    if let Some(cargo_toml) = &args.features {
        let block: String = packages
            .iter()
            .map(|p| {
                let deps: Vec<String> = match &args.forward_features {
                    Some(krate) => vec![format!("\"{krate}/{}\"", p.name)],
                    None => std::iter::once("derive".to_owned())
                        .chain(p.dependencies())
                        .map(|d| format!("\"{d}\""))
                        .collect(),
                };
                format!("{} = [{}]\n", p.name, deps.join(", "))
            })
            .collect();
        let all: Vec<String> = packages.iter().map(|p| format!("\"{}\"", p.name)).collect();
        let block = format!(
            "{block}## Every interface package above.\nall_interfaces = [{}]\n",
            all.join(", ")
        );
        replace_block(cargo_toml, &block)?;
    }
    if let Some(registry) = &args.registry {
        write(registry, &registry_source(&loaded, args.options.borrowed))?;
    }
    if let Some(file) = &args.distro_sources {
        write(file, &distro_sources(&loaded, &args.sources_of)?)?;
    }
    if args.options.shm_forms_only {
        let forms = sources
            .iter()
            .map(|s| s.body.matches("pub struct ").count())
            .sum::<usize>();
        eprintln!(
            "shm-codegen: {forms} `…Shm` forms in {} -> {}",
            rust::count(packages.len(), "package"),
            args.out_dir.display()
        );
        return Ok(());
    }
    eprintln!(
        "shm-codegen: {}, {}, {}, {} -> {}",
        rust::count(packages.len(), "package"),
        rust::count(
            packages.iter().map(|p| p.all_messages().count()).sum(),
            "message type"
        ),
        rust::count(packages.iter().map(|p| p.services.len()).sum(), "service"),
        rust::count(packages.iter().map(|p| p.actions.len()).sum(), "action"),
        args.out_dir.display()
    );
    Ok(())
}

/// The `for_each_interface!` macro: every message type (with its borrowing form
/// where there is one), service and action, as paths under `::shm_cdr::msgs`.
fn registry_source(packages: &[shm_codegen::ast::Package], borrowed: bool) -> String {
    let path = |r: &shm_codegen::ast::TypeRef, suffix: &str| {
        format!(
            "::shm_cdr::msgs::{}::{}::{}{suffix}",
            r.package, r.namespace, r.name
        )
    };
    let mut messages = Vec::new();
    let mut services = Vec::new();
    let mut actions = Vec::new();
    for p in packages {
        for m in p.all_messages() {
            messages.push(path(&m.ty, ""));
        }
        services.extend(p.services.iter().map(|s| path(&s.ty, "")));
        for a in &p.actions {
            services.push(path(&a.send_goal.ty, ""));
            services.push(path(&a.get_result.ty, ""));
            actions.push(path(&a.ty, ""));
        }
    }
    let list = |items: &[String]| {
        items
            .iter()
            .map(|i| format!("            {i},\n"))
            .collect::<String>()
    };
    let with_ref: Vec<String> = if borrowed {
        rust::borrowing_types(packages)
            .iter()
            .map(|r| format!("({}, {})", path(r, ""), path(r, "Ref")))
            .collect()
    } else {
        Vec::new()
    };
    format!(
        "{GENERATED_MARKER}\n\n/// Calls `$callback! {{ messages: [..], borrowed: [(Owned, Ref), ..], services: [..], actions: [..] }}`\n/// with every type generated into `shm_cdr::msgs` (all packages' features on).\n#[macro_export]\n#[doc(hidden)]\nmacro_rules! for_each_interface {{\n    ($callback:ident) => {{\n        $callback! {{\n        messages: [\n{}        ],\n        borrowed: [\n{}        ],\n        services: [\n{}        ],\n        actions: [\n{}        ],\n        }}\n    }};\n}}\n",
        list(&messages),
        list(&with_ref),
        list(&services),
        list(&actions)
    )
}

/// Write `text`, formatted by rustfmt when it is available, to `path`, unless
/// `path` holds exactly that already: a file left as it was keeps its
/// modification time, so regenerating an unchanged set rebuilds nothing.
fn write(path: &Path, text: &str) -> Result<(), String> {
    let formatted = rustfmt(text).map_err(|e| format!("{}: {e}", path.display()))?;
    let text = formatted.as_deref().unwrap_or(text);
    if formatted.is_none() {
        eprintln!(
            "shm-codegen: rustfmt not found; {} is left unformatted",
            path.display()
        );
    }
    if std::fs::read(path).is_ok_and(|old| old == text.as_bytes()) {
        return Ok(());
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// `text` formatted by rustfmt (from its standard input, so no module it
/// names is read), or `None` without rustfmt.
fn rustfmt(text: &str) -> Result<Option<String>, String> {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let mut child = match Command::new("rustfmt")
        .args(["--edition", "2021"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
    {
        Ok(child) => child,
        Err(_) => return Ok(None),
    };
    // Fed from a thread: rustfmt may write before it has read everything.
    let mut stdin = child.stdin.take().ok_or("rustfmt's input is not open")?;
    let input = text.to_owned();
    let feeder = std::thread::spawn(move || stdin.write_all(input.as_bytes()));
    let out = child
        .wait_with_output()
        .map_err(|e| format!("rustfmt: {e}"))?;
    match feeder.join() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(format!("rustfmt's input: {e}")),
        Err(_) => return Err("rustfmt's input: the writer panicked".into()),
    }
    if !out.status.success() {
        return Err(format!("rustfmt failed ({})", out.status));
    }
    String::from_utf8(out.stdout)
        .map(Some)
        .map_err(|e| format!("rustfmt wrote other than UTF-8: {e}"))
}

fn replace_block(cargo_toml: &Path, block: &str) -> Result<(), String> {
    let text = std::fs::read_to_string(cargo_toml)
        .map_err(|e| format!("{}: {e}", cargo_toml.display()))?;
    let (Some(begin), Some(end)) = (text.find(BEGIN), text.find(END)) else {
        return Err(format!(
            "{}: add the lines `{BEGIN}` and `{END}` under [features]",
            cargo_toml.display()
        ));
    };
    let after_begin = begin + BEGIN.len() + 1;
    let new = format!("{}{block}{}", &text[..after_begin], &text[end..]);
    if new == text {
        return Ok(());
    }
    std::fs::write(cargo_toml, new).map_err(|e| format!("{}: {e}", cargo_toml.display()))
}
