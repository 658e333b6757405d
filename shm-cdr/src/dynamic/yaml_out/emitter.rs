//! PyYAML's emitter (`allow_unicode=True`, unlimited width, block or flow
//! style) for the documents messages make: block and flow mappings and
//! sequences of scalars, with PyYAML's choice between plain, single- and
//! double-quoted scalars.

use std::borrow::Cow;
use std::fmt::{self, Write as _};

use super::scalars::resolves_to_non_string;

/// What rosidl_runtime_py turns a message into before PyYAML writes it.
#[derive(Debug)]
pub(super) enum Node<'m> {
    /// A string: quoted where PyYAML would read it back as something else.
    Str(Cow<'m, str>),
    /// A number or boolean, in the form PyYAML writes it.
    Plain(String),
    Seq(Vec<Node<'m>>),
    /// A message's array or sequence: its items are made one at a time as
    /// they are written, so that writing a message takes memory for its
    /// depth, not for its elements.
    List(List<'m>),
    Map(Vec<(&'m str, Node<'m>)>),
}

pub(super) struct List<'m> {
    /// Items shown (`...` follows when some are cut).
    pub(super) len: usize,
    pub(super) cut: bool,
    pub(super) item: Box<dyn Fn(usize) -> Node<'m> + 'm>,
}

impl fmt::Debug for List<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("List")
            .field("len", &self.len)
            .field("cut", &self.cut)
            .finish_non_exhaustive()
    }
}

impl<'m> List<'m> {
    /// How many items are written, `...` included.
    fn written(&self) -> usize {
        self.len + usize::from(self.cut)
    }

    fn node(&self, i: usize) -> Node<'m> {
        if i < self.len {
            (self.item)(i)
        } else {
            Node::Str(Cow::Borrowed("..."))
        }
    }
}

/// `root` written as PyYAML writes one document, in flow style when
/// `flow_style` (else block).
pub(super) fn document(root: &Node<'_>, flow_style: bool) -> String {
    let mut emitter = Emitter::new(flow_style);
    emitter.document(root);
    emitter.out
}

/// What PyYAML's `analyze_scalar` finds in a scalar: which styles can write it.
struct Analysis {
    empty: bool,
    multiline: bool,
    allow_flow_plain: bool,
    allow_block_plain: bool,
    allow_single_quoted: bool,
}

fn is_break(c: char) -> bool {
    matches!(c, '\n' | '\u{85}' | '\u{2028}' | '\u{2029}')
}

fn is_space_or_break(c: char) -> bool {
    matches!(c, '\0' | ' ' | '\t' | '\r') || is_break(c)
}

/// Printable with `allow_unicode`: written as itself in any style.
fn is_printable_unicode(c: char) -> bool {
    c == '\u{85}'
        || ('\u{A0}'..='\u{D7FF}').contains(&c)
        || ('\u{E000}'..='\u{FFFD}').contains(&c)
        || ('\u{10000}'..'\u{10FFFF}').contains(&c)
}

fn analyze(scalar: &str) -> Analysis {
    if scalar.is_empty() {
        return Analysis {
            empty: true,
            multiline: false,
            allow_flow_plain: false,
            allow_block_plain: true,
            allow_single_quoted: true,
        };
    }
    let chars: Vec<char> = scalar.chars().collect();
    let mut block_indicators = false;
    let mut flow_indicators = false;
    let mut line_breaks = false;
    let mut special = false;
    let (mut leading_space, mut leading_break) = (false, false);
    let (mut trailing_space, mut trailing_break) = (false, false);
    let (mut break_space, mut space_break) = (false, false);
    if scalar.starts_with("---") || scalar.starts_with("...") {
        block_indicators = true;
        flow_indicators = true;
    }
    let mut preceded_by_whitespace = true;
    let mut followed_by_whitespace = chars.len() == 1 || is_space_or_break(chars[1]);
    let (mut previous_space, mut previous_break) = (false, false);
    let last = chars.len() - 1;
    for (index, &ch) in chars.iter().enumerate() {
        if index == 0 {
            if "#,[]{}&*!|>'\"%@`".contains(ch) {
                flow_indicators = true;
                block_indicators = true;
            }
            if ch == '?' || ch == ':' {
                flow_indicators = true;
                if followed_by_whitespace {
                    block_indicators = true;
                }
            }
            if ch == '-' && followed_by_whitespace {
                flow_indicators = true;
                block_indicators = true;
            }
        } else {
            if ",?[]{}".contains(ch) {
                flow_indicators = true;
            }
            if ch == ':' {
                flow_indicators = true;
                if followed_by_whitespace {
                    block_indicators = true;
                }
            }
            if ch == '#' && preceded_by_whitespace {
                flow_indicators = true;
                block_indicators = true;
            }
        }
        if is_break(ch) {
            line_breaks = true;
        }
        let printable = ch == '\n'
            || (' '..='~').contains(&ch)
            || (is_printable_unicode(ch) && ch != '\u{FEFF}');
        if !printable {
            special = true;
        }
        if ch == ' ' {
            if index == 0 {
                leading_space = true;
            }
            if index == last {
                trailing_space = true;
            }
            if previous_break {
                break_space = true;
            }
            previous_space = true;
            previous_break = false;
        } else if is_break(ch) {
            if index == 0 {
                leading_break = true;
            }
            if index == last {
                trailing_break = true;
            }
            if previous_space {
                space_break = true;
            }
            previous_space = false;
            previous_break = true;
        } else {
            previous_space = false;
            previous_break = false;
        }
        preceded_by_whitespace = is_space_or_break(ch);
        followed_by_whitespace = chars.get(index + 2).is_none_or(|&c| is_space_or_break(c));
    }
    let mut allow_flow_plain = true;
    let mut allow_block_plain = true;
    let mut allow_single_quoted = true;
    if leading_space || leading_break || trailing_space || trailing_break {
        allow_flow_plain = false;
        allow_block_plain = false;
    }
    if break_space {
        allow_flow_plain = false;
        allow_block_plain = false;
        allow_single_quoted = false;
    }
    if space_break || special {
        allow_flow_plain = false;
        allow_block_plain = false;
        allow_single_quoted = false;
    }
    if line_breaks {
        allow_flow_plain = false;
        allow_block_plain = false;
    }
    if flow_indicators {
        allow_flow_plain = false;
    }
    if block_indicators {
        allow_block_plain = false;
    }
    Analysis {
        empty: false,
        multiline: line_breaks,
        allow_flow_plain,
        allow_block_plain,
        allow_single_quoted,
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Style {
    Plain,
    Single,
    Double,
}

/// Where a node is written (PyYAML's emitter contexts).
#[derive(Clone, Copy, Default)]
struct Context {
    mapping: bool,
    simple_key: bool,
}

/// PyYAML's emitter state for the documents messages make.
struct Emitter {
    out: String,
    flow_style: bool,
    column: usize,
    indent: Option<usize>,
    indents: Vec<Option<usize>>,
    flow_level: usize,
    whitespace: bool,
    indention: bool,
}

const BEST_INDENT: usize = 2;

impl Emitter {
    fn new(flow_style: bool) -> Self {
        Self {
            out: String::new(),
            flow_style,
            column: 0,
            indent: None,
            indents: Vec::new(),
            flow_level: 0,
            whitespace: true,
            indention: true,
        }
    }

    fn document(&mut self, root: &Node<'_>) {
        self.node(root, Context::default());
        // The document's end: a line break.
        self.indent = None;
        self.write_indent();
    }

    fn increase_indent(&mut self, flow: bool, indentless: bool) {
        self.indents.push(self.indent);
        self.indent = match self.indent {
            None if flow => Some(BEST_INDENT),
            None => Some(0),
            Some(i) if !indentless => Some(i + BEST_INDENT),
            Some(i) => Some(i),
        };
    }

    fn pop_indent(&mut self) {
        self.indent = self.indents.pop().flatten();
    }

    fn write_indicator(
        &mut self,
        indicator: &str,
        need_whitespace: bool,
        whitespace: bool,
        indention: bool,
    ) {
        if !self.whitespace && need_whitespace {
            self.out.push(' ');
            self.column += 1;
        }
        self.out.push_str(indicator);
        self.column += indicator.chars().count();
        self.whitespace = whitespace;
        self.indention = self.indention && indention;
    }

    fn write_indent(&mut self) {
        let indent = self.indent.unwrap_or(0);
        if !self.indention || self.column > indent || (self.column == indent && !self.whitespace) {
            self.write_line_break(None);
        }
        if self.column < indent {
            self.whitespace = true;
            for _ in self.column..indent {
                self.out.push(' ');
            }
            self.column = indent;
        }
    }

    fn write_line_break(&mut self, data: Option<char>) {
        self.out.push(data.unwrap_or('\n'));
        self.whitespace = true;
        self.indention = true;
        self.column = 0;
    }

    fn write_text(&mut self, text: &str) {
        self.out.push_str(text);
        self.column += text.chars().count();
    }

    fn node(&mut self, node: &Node<'_>, context: Context) {
        match node {
            Node::Str(s) => self.scalar(s, !resolves_to_non_string(s), context),
            Node::Plain(s) => self.scalar(s, true, context),
            Node::Seq(items) => {
                let each = |e: &mut Self, i: usize| {
                    if let Some(item) = items.get(i) {
                        e.node(item, Context::default());
                    }
                };
                if self.flow_level > 0 || self.flow_style || items.is_empty() {
                    self.flow_sequence(items.len(), each);
                } else {
                    self.block_sequence(items.len(), context, each);
                }
            }
            Node::List(list) => {
                let each = |e: &mut Self, i: usize| e.node(&list.node(i), Context::default());
                let n = list.written();
                if self.flow_level > 0 || self.flow_style || n == 0 {
                    self.flow_sequence(n, each);
                } else {
                    self.block_sequence(n, context, each);
                }
            }
            Node::Map(entries) => {
                // rosidl_runtime_py makes its mapping nodes itself, with no
                // style: `flow_style` reaches only the sequences.
                if self.flow_level > 0 || entries.is_empty() {
                    self.flow_mapping(entries);
                } else {
                    self.block_mapping(entries);
                }
            }
        }
    }

    fn flow_sequence(&mut self, len: usize, mut item: impl FnMut(&mut Self, usize)) {
        self.write_indicator("[", true, true, false);
        self.flow_level += 1;
        self.increase_indent(true, false);
        for i in 0..len {
            if i > 0 {
                self.write_indicator(",", false, false, false);
            }
            item(self, i);
        }
        self.pop_indent();
        self.flow_level -= 1;
        self.write_indicator("]", false, false, false);
    }

    fn flow_mapping(&mut self, entries: &[(&str, Node<'_>)]) {
        self.write_indicator("{", true, true, false);
        self.flow_level += 1;
        self.increase_indent(true, false);
        for (i, (key, value)) in entries.iter().enumerate() {
            if i > 0 {
                self.write_indicator(",", false, false, false);
            }
            if is_simple_key(key) {
                self.key(key, true);
                self.write_indicator(":", false, false, false);
            } else {
                self.write_indicator("?", true, false, false);
                self.key(key, false);
                self.write_indicator(":", true, false, false);
            }
            self.node(
                value,
                Context {
                    mapping: true,
                    simple_key: false,
                },
            );
        }
        self.pop_indent();
        self.flow_level -= 1;
        self.write_indicator("}", false, false, false);
    }

    fn block_sequence(
        &mut self,
        len: usize,
        context: Context,
        mut item: impl FnMut(&mut Self, usize),
    ) {
        let indentless = context.mapping && !self.indention;
        self.increase_indent(false, indentless);
        for i in 0..len {
            self.write_indent();
            self.write_indicator("-", true, false, true);
            item(self, i);
        }
        self.pop_indent();
    }

    fn block_mapping(&mut self, entries: &[(&str, Node<'_>)]) {
        self.increase_indent(false, false);
        for (key, value) in entries {
            self.write_indent();
            if is_simple_key(key) {
                self.key(key, true);
                self.write_indicator(":", false, false, false);
            } else {
                self.write_indicator("?", true, false, true);
                self.key(key, false);
                self.write_indent();
                self.write_indicator(":", true, false, true);
            }
            self.node(
                value,
                Context {
                    mapping: true,
                    simple_key: false,
                },
            );
        }
        self.pop_indent();
    }

    fn key(&mut self, key: &str, simple: bool) {
        self.scalar(
            key,
            !resolves_to_non_string(key),
            Context {
                mapping: true,
                simple_key: simple,
            },
        );
    }

    fn scalar(&mut self, text: &str, implicit: bool, context: Context) {
        self.increase_indent(true, false);
        let analysis = analyze(text);
        let style = self.choose_style(&analysis, implicit, context);
        match style {
            Style::Plain => self.write_plain(text),
            Style::Single => self.write_single_quoted(text),
            Style::Double => self.write_double_quoted(text),
        }
        self.pop_indent();
    }

    fn choose_style(&self, analysis: &Analysis, implicit: bool, context: Context) -> Style {
        let awkward_key = context.simple_key && (analysis.empty || analysis.multiline);
        let plain_here = if self.flow_level > 0 {
            analysis.allow_flow_plain
        } else {
            analysis.allow_block_plain
        };
        if implicit && !awkward_key && plain_here {
            return Style::Plain;
        }
        if analysis.allow_single_quoted && !(context.simple_key && analysis.multiline) {
            return Style::Single;
        }
        Style::Double
    }

    fn write_plain(&mut self, text: &str) {
        if text.is_empty() {
            return;
        }
        if !self.whitespace {
            self.out.push(' ');
            self.column += 1;
        }
        self.whitespace = false;
        self.indention = false;
        // Plain scalars never hold line breaks here, and lines are never
        // folded (unlimited width): the text as it is.
        self.write_text(text);
    }

    fn write_single_quoted(&mut self, text: &str) {
        self.write_indicator("'", true, false, false);
        let chars: Vec<char> = text.chars().collect();
        let (mut spaces, mut breaks) = (false, false);
        let mut start = 0;
        let mut end = 0;
        while end <= chars.len() {
            let ch = chars.get(end).copied();
            if spaces {
                if ch != Some(' ') {
                    let run: String = chars[start..end].iter().collect();
                    self.write_text(&run);
                    start = end;
                }
            } else if breaks {
                if ch.is_none_or(|c| !is_break(c)) {
                    if chars[start] == '\n' {
                        self.write_line_break(None);
                    }
                    for &br in &chars[start..end] {
                        self.write_line_break(Some(br));
                    }
                    self.write_indent();
                    start = end;
                }
            } else if ch.is_none_or(|c| c == ' ' || is_break(c) || c == '\'') && start < end {
                let run: String = chars[start..end].iter().collect();
                self.write_text(&run);
                start = end;
            }
            if ch == Some('\'') {
                self.write_text("''");
                start = end + 1;
            }
            if let Some(c) = ch {
                spaces = c == ' ';
                breaks = is_break(c);
            }
            end += 1;
        }
        self.write_indicator("'", false, false, false);
    }

    fn write_double_quoted(&mut self, text: &str) {
        self.write_indicator("\"", true, false, false);
        let mut run = String::new();
        for ch in text.chars() {
            let plain = (' '..='~').contains(&ch)
                || ('\u{A0}'..='\u{D7FF}').contains(&ch)
                || ('\u{E000}'..='\u{FFFD}').contains(&ch);
            if plain
                && !matches!(
                    ch,
                    '"' | '\\' | '\u{85}' | '\u{2028}' | '\u{2029}' | '\u{FEFF}'
                )
            {
                run.push(ch);
                continue;
            }
            let escaped = match ch {
                '\0' => "\\0".to_owned(),
                '\u{07}' => "\\a".to_owned(),
                '\u{08}' => "\\b".to_owned(),
                '\t' => "\\t".to_owned(),
                '\n' => "\\n".to_owned(),
                '\u{0B}' => "\\v".to_owned(),
                '\u{0C}' => "\\f".to_owned(),
                '\r' => "\\r".to_owned(),
                '\u{1B}' => "\\e".to_owned(),
                '"' => "\\\"".to_owned(),
                '\\' => "\\\\".to_owned(),
                '\u{85}' => "\\N".to_owned(),
                '\u{A0}' => "\\_".to_owned(),
                '\u{2028}' => "\\L".to_owned(),
                '\u{2029}' => "\\P".to_owned(),
                c if u32::from(c) <= 0xFF => format!("\\x{:02X}", u32::from(c)),
                c if u32::from(c) <= 0xFFFF => format!("\\u{:04X}", u32::from(c)),
                c => format!("\\U{:08X}", u32::from(c)),
            };
            run.push_str(&escaped);
        }
        let _ = write!(self.out, "{run}");
        self.column += run.chars().count();
        self.write_indicator("\"", false, false, false);
    }
}

/// PyYAML's `check_simple_key` for a string key.
fn is_simple_key(key: &str) -> bool {
    let analysis = analyze(key);
    key.chars().count() < 128 && !analysis.empty && !analysis.multiline
}
