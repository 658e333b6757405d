//! Bounds on YAML and JSON text from outside (message values given to
//! `topic pub`, parameter files, recordings' `metadata.yaml`), checked before
//! a parser sees it: the YAML parser takes time quadratic in how deep flow
//! collections (`[[[…]]]`) nest, so a few hundred kilobytes of brackets
//! would hold it for minutes.

use std::fmt;

/// The longest text read, in bytes. Parsed, YAML takes some thirty times
/// its length in memory: this keeps a reader within about 256 MiB, and
/// holds any parameter file, message value or `metadata.yaml` many times
/// over.
pub const MAX_TEXT_LEN: usize = 8 << 20;

/// How deep `[…]` and `{…}` may nest (the YAML reader refuses more than 128
/// levels of any nesting anyway, once it has parsed them).
pub const MAX_FLOW_NESTING: usize = 128;

/// Why text was not read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextLimitError {
    /// What is past which limit.
    pub reason: String,
}

impl fmt::Display for TextLimitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.reason)
    }
}

impl std::error::Error for TextLimitError {}

/// The longest part of outside text an error quotes, in bytes.
pub const QUOTED_LEN: usize = 96;

/// `text` as an error message quotes outside text: whole if short, else its
/// start and its length.
///
/// ```
/// use shm_cdr::text_limits::quoted;
///
/// assert_eq!(quoted("/chatter"), "/chatter");
/// assert_eq!(quoted(&"n".repeat(1 << 20)), format!("{}… (1048576 bytes)", "n".repeat(96)));
/// ```
pub fn quoted(text: &str) -> String {
    if text.len() <= QUOTED_LEN {
        return text.to_owned();
    }
    let mut end = QUOTED_LEN;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}… ({} bytes)", &text[..end], text.len())
}

/// The text of the file at `path`, refused without reading it all if it is
/// longer than [`MAX_TEXT_LEN`] (a path given as a file may be a device
/// that never ends, such as `/dev/zero`).
pub fn read_text_file(path: &std::path::Path) -> std::io::Result<String> {
    use std::io::Read;
    let file = std::fs::File::open(path)?;
    let mut text = String::new();
    file.take(MAX_TEXT_LEN as u64 + 1)
        .read_to_string(&mut text)?;
    if text.len() > MAX_TEXT_LEN {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("longer than {MAX_TEXT_LEN} bytes, the most read as text"),
        ));
    }
    Ok(text)
}

/// Check YAML (or JSON) text against [`MAX_TEXT_LEN`] and
/// [`MAX_FLOW_NESTING`], in one pass that follows quotes and comments as a
/// YAML reader does.
///
/// ```
/// use shm_cdr::text_limits::check_yaml;
///
/// assert!(check_yaml("data: [[1, 2], {a: '[[[['}]  # ]]]").is_ok());
/// let deep = format!("data: {}{}", "[".repeat(200), "]".repeat(200));
/// assert!(check_yaml(&deep).unwrap_err().to_string().contains("nest more than 128"));
/// ```
pub fn check_yaml(text: &str) -> Result<(), TextLimitError> {
    if text.len() > MAX_TEXT_LEN {
        return Err(TextLimitError {
            reason: format!(
                "the text is {} bytes long, more than {MAX_TEXT_LEN} are read",
                text.len()
            ),
        });
    }
    #[derive(PartialEq)]
    enum In {
        Plain,
        Single,
        Double { escaped: bool },
        Comment,
    }
    let mut state = In::Plain;
    let mut depth = 0usize;
    // Whether the last character ends a token (a quote may start after it),
    // and whether it is a space (a comment may).
    let mut boundary = true;
    let mut spaced;
    let mut reopen = false;
    for (line, text_line) in text.split('\n').enumerate() {
        if state == In::Comment {
            state = In::Plain;
        }
        boundary = boundary || state == In::Plain;
        spaced = true;
        for c in text_line.chars() {
            match &mut state {
                In::Comment => break,
                In::Single => {
                    if c == '\'' {
                        state = In::Plain;
                        reopen = true;
                    }
                    boundary = false;
                    spaced = false;
                    continue;
                }
                In::Double { escaped } => {
                    if *escaped {
                        *escaped = false;
                    } else if c == '\\' {
                        *escaped = true;
                    } else if c == '"' {
                        state = In::Plain;
                    }
                    boundary = false;
                    spaced = false;
                    continue;
                }
                In::Plain => {}
            }
            // `''` inside single quotes is a quote: the string goes on.
            let reopened = std::mem::take(&mut reopen) && c == '\'';
            match c {
                '\'' if reopened => state = In::Single,
                '#' if spaced => state = In::Comment,
                '\'' if boundary => state = In::Single,
                '"' if boundary => state = In::Double { escaped: false },
                '[' | '{' => {
                    depth += 1;
                    if depth > MAX_FLOW_NESTING {
                        return Err(TextLimitError {
                            reason: format!(
                                "line {}: lists and mappings nest more than \
                                 {MAX_FLOW_NESTING} levels deep",
                                line + 1
                            ),
                        });
                    }
                }
                ']' | '}' => depth = depth.saturating_sub(1),
                _ => {}
            }
            spaced = c.is_whitespace();
            boundary = spaced || matches!(c, '[' | '{' | ',' | ':' | '-' | '?');
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_cuts_long_text_at_a_char_boundary() {
        let long = "é".repeat(1000);
        let shown = quoted(&long);
        assert!(shown.len() < 120, "{shown}");
        assert!(shown.ends_with("… (2000 bytes)"), "{shown}");
    }

    #[test]
    fn brackets_in_quotes_and_comments_do_not_count() {
        let nested = |n: usize| format!("{}{}", "[".repeat(n), "]".repeat(n));
        assert!(check_yaml(&nested(MAX_FLOW_NESTING)).is_ok());
        assert!(check_yaml(&nested(MAX_FLOW_NESTING + 1)).is_err());
        let open = "[".repeat(300);
        for text in [
            format!("a: '{open}'"),
            format!("a: \"\\\"{open}\""),
            format!("a: 1 # {open}\nb: 2"),
            format!("a: 'it''s {open}'"),
        ] {
            assert!(check_yaml(&text).is_ok(), "{text}");
        }
        // An apostrophe inside a plain scalar opens no quote.
        assert!(check_yaml(&format!("a: it's\nb: {}", nested(200))).is_err());
        // Unbalanced closers do not go below zero.
        assert!(check_yaml("]]]]").is_ok());
    }
}
