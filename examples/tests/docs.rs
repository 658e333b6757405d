//! The README and the guide hold together: every chapter is in the book and
//! compiled as a doctest, every snippet that is not compiled says where it is
//! compiled or why not, every relative link and anchor resolves, and nothing
//! in them narrates the project's own history.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The README and every Markdown file of the guide.
fn documents() -> Vec<PathBuf> {
    let mut files = vec![root().join("README.md")];
    let mut chapters: Vec<_> = std::fs::read_dir(root().join("docs/src"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "md"))
        .collect();
    chapters.sort();
    files.extend(chapters);
    files
}

/// `(info string, first line number, body)` of every fenced code block.
fn code_blocks(text: &str) -> Vec<(String, usize, String)> {
    let mut blocks = Vec::new();
    let mut open: Option<(String, usize, String)> = None;
    for (number, line) in text.lines().enumerate() {
        match (&mut open, line.strip_prefix("```")) {
            (None, Some(info)) => open = Some((info.trim().to_string(), number + 1, String::new())),
            (Some(_), Some("")) => blocks.extend(open.take()),
            (Some((_, _, body)), _) => {
                body.push_str(line);
                body.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "a code block is not closed");
    blocks
}

#[test]
fn every_chapter_is_in_the_book_and_compiled() {
    let summary = read(&root().join("docs/src/SUMMARY.md"));
    let listed: BTreeSet<String> = summary
        .split("](")
        .skip(1)
        .filter_map(|rest| rest.split(')').next())
        .map(str::to_string)
        .collect();
    let on_disk: BTreeSet<String> = documents()
        .iter()
        .filter_map(|path| path.strip_prefix(root().join("docs/src")).ok())
        .map(|path| path.display().to_string())
        .filter(|name| name != "SUMMARY.md")
        .collect();
    assert_eq!(
        listed, on_disk,
        "docs/src/SUMMARY.md and the files in docs/src"
    );
    let doctests = read(&root().join("examples/src/lib.rs"));
    for chapter in &listed {
        assert!(
            doctests.contains(&format!("\"../../docs/src/{chapter}\"")),
            "{chapter} is not compiled as a doctest: list it in examples/src/lib.rs (mod docs)"
        );
    }
    assert!(doctests.contains("\"../../README.md\""));
}

#[test]
fn every_snippet_is_compiled_or_says_where_it_is() {
    for path in documents() {
        let text = read(&path);
        let lines: Vec<&str> = text.lines().collect();
        for (info, line, body) in code_blocks(&text) {
            let at = format!("{}:{line}", path.display());
            assert!(
                !info.is_empty(),
                "{at}: a code block without a language (rustdoc would compile it as Rust)"
            );
            if !(info.starts_with("rust") && info.contains("ignore")) {
                continue;
            }
            // The line before the fence says where the code is compiled.
            let note = lines[line.saturating_sub(2)].trim();
            if let Some(file) = note
                .strip_prefix("<!-- from ")
                .and_then(|rest| rest.strip_suffix(" -->"))
            {
                let source = read(&root().join(file));
                assert!(
                    source.contains(body.trim()),
                    "{at}: the snippet is not in {file} word for word"
                );
            } else {
                assert!(
                    note.starts_with("<!-- not compiled: "),
                    "{at}: an ignored snippet needs `<!-- from FILE -->` or `<!-- not compiled: why -->` above it"
                );
            }
        }
    }
}

/// mdBook's anchor for a heading.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> BTreeSet<String> {
    let mut in_code = false;
    let mut found = BTreeSet::new();
    for line in text.lines() {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if !in_code {
            if let Some(heading) = line.strip_prefix('#') {
                found.insert(anchor(heading.trim_start_matches('#')));
            }
        }
    }
    found
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    for path in documents() {
        let text = read(&path);
        let dir = path.parent().unwrap();
        for target in text
            .split("](")
            .skip(1)
            .filter_map(|rest| rest.split(')').next())
        {
            if target.starts_with("http") || target.contains(' ') {
                continue;
            }
            let (file, fragment) = target.split_once('#').unwrap_or((target, ""));
            let linked = if file.is_empty() {
                path.clone()
            } else {
                dir.join(file)
            };
            assert!(
                linked.exists(),
                "{}: link to {target}: no such file",
                path.display()
            );
            if !fragment.is_empty() {
                assert!(
                    anchors(&read(&linked)).contains(fragment),
                    "{}: link to {target}: no such heading",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn the_documents_speak_of_the_project_not_its_history() {
    // Built here, so that this file does not itself read as history.
    let word = "session";
    let mut history: Vec<String> = (1..=9).map(|n| format!("{word} {n}")).collect();
    for before in ["this", "last", "next", "earlier", "previous", "until", "in"] {
        history.push(format!("{before} {word}"));
    }
    history.extend(["earlier run", "before this", "used to"].map(String::from));
    for path in documents() {
        let text = read(&path).to_lowercase();
        for phrase in &history {
            assert!(
                !text.contains(phrase.as_str()),
                "{}: \"{phrase}\" narrates the project's history; say what is true now",
                path.display()
            );
        }
    }
    let readme = read(&root().join("README.md"));
    assert!(
        readme.lines().count() <= 300,
        "the README is the front door: at most 300 lines"
    );
}
