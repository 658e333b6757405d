//! Reading `.msg`, `.srv` and `.action` files as rosidl_adapter reads them, with
//! an error for each mistake that names the file, the line and what to write.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::ast::{
    Action, BaseType, Constant, Container, Field, FieldType, Message, Package, Primitive, Service,
    TypeRef, Value,
};

/// A mistake in an interface file, or a file that could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    /// The file.
    pub file: PathBuf,
    /// The 1-based line, or 0 when the error concerns the whole file.
    pub line: usize,
    /// What is wrong, and what to write instead.
    pub message: String,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.file.display(), self.message)
        } else {
            write!(f, "{}:{}: {}", self.file.display(), self.line, self.message)
        }
    }
}

impl std::error::Error for Error {}

/// Read the interface package in `dir` (laid out as `<pkg>/{msg,srv,action}/…`);
/// the package name is the folder's name.
pub fn load_package(dir: &Path) -> Result<Package, Error> {
    let whole = |message: String| Error {
        file: dir.to_owned(),
        line: 0,
        message,
    };
    let name = dir
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| whole("the folder name is not a package name".into()))?
        .to_owned();
    check_package_name(&name).map_err(whole)?;
    let mut package = Package {
        name: name.clone(),
        ..Package::default()
    };
    for (path, stem) in files(dir, "msg", "msg")? {
        let text = read(&path)?;
        package
            .messages
            .push(parse_message(&text, &path, &name, &stem)?);
    }
    for (path, stem) in files(dir, "srv", "srv")? {
        let text = read(&path)?;
        package
            .services
            .push(parse_service(&text, &path, &name, &stem)?);
    }
    for (path, stem) in files(dir, "action", "action")? {
        let text = read(&path)?;
        package
            .actions
            .push(parse_action(&text, &path, &name, &stem)?);
    }
    if package.messages.is_empty() && package.services.is_empty() && package.actions.is_empty() {
        return Err(whole(
            "no interface files: expected msg/*.msg, srv/*.srv or action/*.action inside".into(),
        ));
    }
    Ok(package)
}

fn read(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|e| Error {
        file: path.to_owned(),
        line: 0,
        message: format!("cannot read: {e}"),
    })
}

/// The `*.ext` files in `dir/sub`, sorted, with their stems.
fn files(dir: &Path, sub: &str, ext: &str) -> Result<Vec<(PathBuf, String)>, Error> {
    let folder = dir.join(sub);
    if !folder.is_dir() {
        return Ok(Vec::new());
    }
    let entries = std::fs::read_dir(&folder).map_err(|e| Error {
        file: folder.clone(),
        line: 0,
        message: format!("cannot list: {e}"),
    })?;
    let mut out = Vec::new();
    for entry in entries {
        let path = entry
            .map_err(|e| Error {
                file: folder.clone(),
                line: 0,
                message: format!("cannot list: {e}"),
            })?
            .path();
        if path.extension().and_then(|e| e.to_str()) == Some(ext) {
            if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                out.push((path.clone(), stem.to_owned()));
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Parse the text of `<package>/msg/<name>.msg`.
pub fn parse_message(text: &str, file: &Path, package: &str, name: &str) -> Result<Message, Error> {
    let ty = own_type(file, package, "msg", name)?;
    let lines: Vec<&str> = text.lines().collect();
    let mut message = parse_section(&lines, 0, file, ty)?;
    message.source = Some(source_text(text));
    Ok(message)
}

/// A file's text as rosidl reports it: its lines joined by `\n`, no newline at
/// the end.
fn source_text(text: &str) -> String {
    text.lines().collect::<Vec<_>>().join("\n")
}

/// Parse the text of `<package>/srv/<name>.srv`: request `---` response.
pub fn parse_service(text: &str, file: &Path, package: &str, name: &str) -> Result<Service, Error> {
    let lines: Vec<&str> = text.lines().collect();
    let sections = split_sections(
        &lines,
        file,
        2,
        "a .srv file is a request and a response separated by a `---` line",
    )?;
    let request = parse_section(
        sections[0].1,
        sections[0].0,
        file,
        own_type(file, package, "srv", &format!("{name}_Request"))?,
    )?;
    let response = parse_section(
        sections[1].1,
        sections[1].0,
        file,
        own_type(file, package, "srv", &format!("{name}_Response"))?,
    )?;
    let doc = request.doc.clone();
    let mut service = service(
        own_type(file, package, "srv", name)?,
        request,
        response,
        doc,
    );
    service.source = Some(source_text(text));
    Ok(service)
}

/// Parse the text of `<package>/action/<name>.action`: goal `---` result `---`
/// feedback, and derive the services and message rosidl builds from them.
pub fn parse_action(text: &str, file: &Path, package: &str, name: &str) -> Result<Action, Error> {
    let lines: Vec<&str> = text.lines().collect();
    let sections = split_sections(
        &lines,
        file,
        3,
        "an .action file is a goal, a result and a feedback separated by `---` lines",
    )?;
    let part = |i: usize, suffix: &str| -> Result<Message, Error> {
        let ty = own_type(file, package, "action", &format!("{name}_{suffix}"))?;
        parse_section(sections[i].1, sections[i].0, file, ty)
    };
    let goal = part(0, "Goal")?;
    let result = part(1, "Result")?;
    let feedback = part(2, "Feedback")?;
    let action_type = |suffix: &str| TypeRef {
        package: package.to_owned(),
        namespace: "action".into(),
        name: format!("{name}{suffix}"),
    };
    let uuid = TypeRef {
        package: "unique_identifier_msgs".into(),
        namespace: "msg".into(),
        name: "UUID".into(),
    };
    let time = TypeRef {
        package: "builtin_interfaces".into(),
        namespace: "msg".into(),
        name: "Time".into(),
    };
    let field = |name: &str, base: BaseType, doc: &str| Field {
        name: name.into(),
        ty: FieldType {
            base,
            container: Container::Single,
        },
        default: None,
        doc: vec![doc.into()],
    };
    let message = |suffix: &str, fields: Vec<Field>| Message {
        ty: action_type(suffix),
        fields,
        constants: Vec::new(),
        doc: Vec::new(),
        source: None,
    };
    let goal_id = || {
        field(
            "goal_id",
            BaseType::Message(uuid.clone()),
            "The goal's unique id.",
        )
    };
    let send_goal = service(
        action_type("_SendGoal"),
        message(
            "_SendGoal_Request",
            vec![
                goal_id(),
                field("goal", BaseType::Message(goal.ty.clone()), "The goal."),
            ],
        ),
        message(
            "_SendGoal_Response",
            vec![
                field(
                    "accepted",
                    BaseType::Primitive(Primitive::Bool),
                    "Whether the server accepted the goal.",
                ),
                field(
                    "stamp",
                    BaseType::Message(time.clone()),
                    "When the server accepted it.",
                ),
            ],
        ),
        vec![format!("Sends a goal of `{package}/action/{name}`.")],
    );
    let get_result = service(
        action_type("_GetResult"),
        message("_GetResult_Request", vec![goal_id()]),
        message(
            "_GetResult_Response",
            vec![
                field(
                    "status",
                    BaseType::Primitive(Primitive::Int8),
                    "The goal's final status (`action_msgs/msg/GoalStatus`).",
                ),
                field(
                    "result",
                    BaseType::Message(result.ty.clone()),
                    "The result.",
                ),
            ],
        ),
        vec![format!(
            "Waits for the result of a goal of `{package}/action/{name}`."
        )],
    );
    let feedback_message = message(
        "_FeedbackMessage",
        vec![
            goal_id(),
            field(
                "feedback",
                BaseType::Message(feedback.ty.clone()),
                "The feedback.",
            ),
        ],
    );
    let doc = goal.doc.clone();
    Ok(Action {
        ty: own_type(file, package, "action", name)?,
        goal,
        result,
        feedback,
        send_goal,
        get_result,
        feedback_message,
        doc,
        source: Some(source_text(text)),
    })
}

/// A service from its request and response, with the event message rosidl adds.
fn service(ty: TypeRef, request: Message, response: Message, doc: Vec<String>) -> Service {
    let sequence_of = |r: &TypeRef, name: &str, doc: &str| Field {
        name: name.into(),
        ty: FieldType {
            base: BaseType::Message(r.clone()),
            container: Container::BoundedSequence(1),
        },
        default: None,
        doc: vec![doc.into()],
    };
    let event = Message {
        ty: TypeRef {
            name: format!("{}_Event", ty.name),
            ..ty.clone()
        },
        fields: vec![
            Field {
                name: "info".into(),
                ty: FieldType {
                    base: BaseType::Message(TypeRef {
                        package: "service_msgs".into(),
                        namespace: "msg".into(),
                        name: "ServiceEventInfo".into(),
                    }),
                    container: Container::Single,
                },
                default: None,
                doc: vec!["What happened, when, and to which call.".into()],
            },
            sequence_of(
                &request.ty,
                "request",
                "The request, if the event carries it.",
            ),
            sequence_of(
                &response.ty,
                "response",
                "The response, if the event carries it.",
            ),
        ],
        constants: Vec::new(),
        doc: vec![format!("An introspection event of `{}`.", ty.full_name())],
        source: None,
    };
    Service {
        ty,
        request,
        response,
        event,
        doc,
        source: None,
    }
}

fn own_type(file: &Path, package: &str, namespace: &str, name: &str) -> Result<TypeRef, Error> {
    check_package_name(package).map_err(|message| Error {
        file: file.to_owned(),
        line: 0,
        message,
    })?;
    let stem = name.split('_').next().unwrap_or(name);
    if !is_type_name(stem) {
        return Err(Error {
            file: file.to_owned(),
            line: 0,
            message: format!(
                "`{stem}` is not a valid interface name: it starts with an uppercase letter and holds only letters and digits (rename the file, e.g. `MyType.{namespace}`)"
            ),
        });
    }
    Ok(TypeRef {
        package: package.into(),
        namespace: namespace.into(),
        name: name.into(),
    })
}

fn check_package_name(name: &str) -> Result<(), String> {
    if is_lower_name(name) {
        Ok(())
    } else {
        Err(format!(
            "`{name}` is not a valid package name: lowercase letters, digits and single `_`, starting with a letter"
        ))
    }
}

/// The `---`-separated sections of a file, each with the index of its first line.
fn split_sections<'a>(
    lines: &'a [&'a str],
    file: &Path,
    count: usize,
    what: &str,
) -> Result<Vec<(usize, &'a [&'a str])>, Error> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, line) in lines.iter().enumerate() {
        if line.trim() == "---" {
            out.push((start, &lines[start..i]));
            start = i + 1;
        }
    }
    out.push((start, &lines[start..]));
    if out.len() != count {
        return Err(Error {
            file: file.to_owned(),
            line: if out.len() > count { out[count].0 } else { 0 },
            message: format!("found {} sections: {what}", out.len()),
        });
    }
    Ok(out)
}

/// Parse one message definition: `lines` start at line index `first` of `file`.
fn parse_section(lines: &[&str], first: usize, file: &Path, ty: TypeRef) -> Result<Message, Error> {
    let mut message = Message {
        ty,
        fields: Vec::new(),
        constants: Vec::new(),
        doc: Vec::new(),
        source: None,
    };
    // Comment lines not yet attached to anything.
    let mut pending: Vec<String> = Vec::new();
    let mut seen_definition = false;
    for (i, raw) in lines.iter().enumerate() {
        let line_no = first + i + 1;
        let error = |message: String| Error {
            file: file.to_owned(),
            line: line_no,
            message,
        };
        let (code, comment) = split_comment(raw);
        let code = code.trim();
        if code.is_empty() {
            match comment {
                Some(text) => pending.push(text),
                None => {
                    // A blank line closes the opening comment of the file; other
                    // floating comments belong to nothing.
                    if !seen_definition && message.doc.is_empty() && !pending.is_empty() {
                        message.doc = std::mem::take(&mut pending);
                    } else {
                        pending.clear();
                    }
                }
            }
            continue;
        }
        seen_definition = true;
        let mut doc = std::mem::take(&mut pending);
        doc.extend(comment);
        parse_definition(code, doc, &mut message).map_err(error)?;
    }
    if !seen_definition && message.doc.is_empty() {
        message.doc = pending;
    }
    Ok(message)
}

/// Parse one field or constant line (comment removed) into `message`.
fn parse_definition(code: &str, doc: Vec<String>, message: &mut Message) -> Result<(), String> {
    let (type_text, rest) = split_token(code);
    let rest = rest.trim_start();
    let ty = parse_type(type_text, &message.ty)?;
    // A constant is `TYPE NAME=value`; a field is `type name [default]`.
    let name_end = rest
        .find(|c: char| c.is_whitespace() || c == '=')
        .unwrap_or(rest.len());
    let (name, after) = rest.split_at(name_end);
    if name.is_empty() {
        return Err(format!(
            "`{code}` has a type but no name: write `{type_text} my_field`"
        ));
    }
    let after = after.trim_start();
    if let Some(value_text) = after.strip_prefix('=') {
        let BaseType::Primitive(primitive) = ty.base else {
            return Err(format!(
                "constant `{name}` has a message type: constants are primitives or strings"
            ));
        };
        if ty.container != Container::Single {
            return Err(format!("constant `{name}` is an array or sequence: constants are single primitives or strings"));
        }
        if !is_constant_name(name) {
            return Err(format!(
                "`{name}` is not a valid constant name: uppercase letters, digits and single `_`, starting with a letter (e.g. `MAX_SPEED`)"
            ));
        }
        if message.constants.iter().any(|c| c.name == name) {
            return Err(format!("constant `{name}` is defined twice"));
        }
        let value = parse_scalar(value_text.trim(), primitive)
            .map_err(|e| format!("constant `{name}`: {e}"))?;
        message.constants.push(Constant {
            name: name.into(),
            ty: primitive,
            value,
            doc,
        });
        return Ok(());
    }
    if !is_lower_name(name) {
        return Err(format!(
            "`{name}` is not a valid field name: lowercase letters, digits and single `_`, starting with a letter and not ending with `_` (a constant is written `{type_text} NAME=value`)"
        ));
    }
    if message.fields.iter().any(|f| f.name == name) {
        return Err(format!("field `{name}` is defined twice"));
    }
    let default = if after.is_empty() {
        None
    } else {
        let BaseType::Primitive(primitive) = ty.base else {
            return Err(format!(
                "field `{name}` of a message type cannot have a default value"
            ));
        };
        Some(
            parse_default(after, primitive, ty.container)
                .map_err(|e| format!("default of `{name}`: {e}"))?,
        )
    };
    message.fields.push(Field {
        name: name.into(),
        ty,
        default,
        doc,
    });
    Ok(())
}

/// Split a line into its code and its comment (the text after a `#` outside
/// quotes, with one leading space removed).
fn split_comment(line: &str) -> (&str, Option<String>) {
    for (i, c) in crate::python::Unquoted::new(line) {
        if c == '#' {
            let text = &line[i + 1..];
            let text = text.strip_prefix(' ').unwrap_or(text).trim_end();
            return (&line[..i], Some(text.to_owned()));
        }
    }
    (line, None)
}

fn split_token(s: &str) -> (&str, &str) {
    let s = s.trim_start();
    let end = s.find(char::is_whitespace).unwrap_or(s.len());
    s.split_at(end)
}

/// `base`, `base[]`, `base[N]`, `base[<=N]`, where base is a primitive,
/// `string<=N`, `Name`, `pkg/Name` or `pkg/msg/Name`.
fn parse_type(text: &str, own: &TypeRef) -> Result<FieldType, String> {
    let (base_text, container) = match text.find('[') {
        Some(open) => {
            let Some(inner) = text[open + 1..].strip_suffix(']') else {
                return Err(format!(
                    "`{text}`: an array is written `T[N]`, a sequence `T[]` or `T[<=N]`"
                ));
            };
            let container = if inner.is_empty() {
                Container::Sequence
            } else if let Some(bound) = inner.strip_prefix("<=") {
                Container::BoundedSequence(parse_size(bound, text)?)
            } else {
                Container::Array(parse_size(inner, text)?)
            };
            (&text[..open], container)
        }
        None => (text, Container::Single),
    };
    let base = if let Some((name, bound)) = base_text.split_once("<=") {
        let bound = parse_size(bound, text)?;
        match name {
            "string" => BaseType::Primitive(Primitive::String(Some(bound))),
            "wstring" => BaseType::Primitive(Primitive::WString(Some(bound))),
            _ => {
                return Err(format!(
                    "`{text}`: only `string` and `wstring` take a bound (`string<=N`)"
                ))
            }
        }
    } else if let Some(primitive) = Primitive::from_msg_name(base_text) {
        BaseType::Primitive(primitive)
    } else {
        BaseType::Message(parse_type_ref(base_text, own)?)
    };
    Ok(FieldType { base, container })
}

fn parse_size(text: &str, whole: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("`{whole}`: `{text}` is not a positive size")),
    }
}

fn parse_type_ref(text: &str, own: &TypeRef) -> Result<TypeRef, String> {
    let parts: Vec<&str> = text.split('/').collect();
    let (package, name) = match parts.as_slice() {
        // rosidl_adapter's one special case: a bare `Header` is std_msgs'.
        ["Header"] => ("std_msgs", "Header"),
        [name] => (own.package.as_str(), *name),
        [package, name] | [package, "msg", name] => (*package, *name),
        _ => {
            return Err(format!(
                "`{text}` is not a type: expected a primitive, `Name` or `pkg/Name`"
            ))
        }
    };
    if !is_lower_name(package) {
        return Err(format!("`{text}`: `{package}` is not a valid package name"));
    }
    if !is_type_name(name) {
        let hint = if name.chars().next().is_some_and(|c| c.is_ascii_lowercase()) {
            " (primitive types are bool, byte, char, int8…uint64, float32, float64, string, wstring)"
        } else {
            ""
        };
        return Err(format!("unknown type `{text}`{hint}"));
    }
    Ok(TypeRef {
        package: package.into(),
        namespace: "msg".into(),
        name: name.into(),
    })
}

/// A default value: a scalar, or `[a, b, …]` for arrays and sequences.
fn parse_default(text: &str, primitive: Primitive, container: Container) -> Result<Value, String> {
    if container == Container::Single {
        return parse_scalar(text, primitive);
    }
    let Some(inner) = text.strip_prefix('[').and_then(|t| t.strip_suffix(']')) else {
        return Err(format!(
            "`{text}`: the default of an array or sequence is written `[a, b, c]`"
        ));
    };
    let items = crate::python::split_list(inner)
        .ok_or_else(|| "a string in the list is not closed".to_owned())?;
    if items.iter().any(|i| i.is_empty()) {
        return Err("empty item in the list".into());
    }
    let len = items.len();
    match container {
        Container::Array(n) if len != n => return Err(format!("{len} values for an array of {n}")),
        Container::BoundedSequence(n) if len > n => {
            return Err(format!("{len} values for a sequence of at most {n}"))
        }
        _ => {}
    }
    items
        .into_iter()
        .map(|item| parse_scalar(item, primitive))
        .collect::<Result<Vec<_>, _>>()
        .map(Value::List)
}

fn parse_scalar(text: &str, primitive: Primitive) -> Result<Value, String> {
    if text.is_empty() {
        return Err("no value after the name".into());
    }
    match primitive {
        Primitive::Bool => match text {
            "true" | "True" | "1" => Ok(Value::Bool(true)),
            "false" | "False" | "0" => Ok(Value::Bool(false)),
            _ => Err(format!("`{text}` is not a bool: write `true` or `false`")),
        },
        Primitive::String(bound) | Primitive::WString(bound) => {
            let value = unquote(text)?;
            let len = match primitive {
                Primitive::WString(_) => value.encode_utf16().count(),
                _ => value.len(),
            };
            match bound {
                Some(bound) if len > bound => {
                    Err(format!("`{text}` is longer than the bound {bound}"))
                }
                _ => Ok(Value::Str(value)),
            }
        }
        Primitive::Float32 | Primitive::Float64 => match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Value::Float(format!("{v:?}"))),
            _ => Err(format!("`{text}` is not a finite number")),
        },
        _ => {
            let (lo, hi) = primitive.int_range().unwrap_or((0, 0));
            let parsed = parse_int(text).ok_or_else(|| format!("`{text}` is not an integer"))?;
            if parsed < lo || parsed > hi {
                return Err(format!("{parsed} is out of range {lo}..={hi}"));
            }
            Ok(Value::Int(parsed))
        }
    }
}

fn parse_int(text: &str) -> Option<i128> {
    let (negative, digits) = match text.strip_prefix('-') {
        Some(d) => (true, d),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let value = if let Some(hex) = digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
    {
        i128::from_str_radix(hex, 16).ok()?
    } else {
        digits.parse::<i128>().ok()?
    };
    Some(if negative { -value } else { value })
}

/// A string value: quoted with `"` or `'` (with `\` escapes), or bare.
fn unquote(text: &str) -> Result<String, String> {
    let mut chars = text.chars();
    let Some(q @ ('"' | '\'')) = chars.next() else {
        return Ok(text.to_owned());
    };
    let mut out = String::new();
    let mut escaped = false;
    let mut closed = false;
    for c in chars.by_ref() {
        if escaped {
            match c {
                'n' => out.push('\n'),
                't' => out.push('\t'),
                other if other == q || other == '\\' => out.push(other),
                other => {
                    out.push('\\');
                    out.push(other);
                }
            }
            escaped = false;
        } else if c == '\\' {
            escaped = true;
        } else if c == q {
            closed = true;
            break;
        } else {
            out.push(c);
        }
    }
    if !closed {
        return Err(format!("`{text}`: the string is not closed with {q}"));
    }
    if !chars.as_str().trim().is_empty() {
        return Err(format!("`{text}`: text after the closing quote"));
    }
    Ok(out)
}

/// rosidl's rule for package and field names.
fn is_lower_name(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_lowercase())
        && s.chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !s.contains("__")
        && !s.ends_with('_')
}

/// rosidl's rule for message names: an uppercase letter, then letters and digits.
fn is_type_name(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && s.chars().all(|c| c.is_ascii_alphanumeric())
}

/// rosidl's rule for constant names.
fn is_constant_name(s: &str) -> bool {
    s.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && s.chars()
            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
        && !s.contains("__")
        && !s.ends_with('_')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(text: &str) -> Result<Message, Error> {
        parse_message(text, Path::new("pkg/msg/Test.msg"), "pkg", "Test")
    }

    #[test]
    fn fields_constants_defaults_and_comments() {
        let m = msg("# A test.\n# Second line.\n\n# The id.\nuint8 id 5 # trailing\nstring<=4 name \"a#b\"\nint32 MAX=-3\nstring S='it\\'s'\nfloat64[3] v [1, 2.5, -3]\npkg2/Other[<=2] others\nHeader h\n").unwrap();
        assert_eq!(m.doc, ["A test.", "Second line."]);
        assert_eq!(m.fields[0].doc, ["The id.", "trailing"]);
        assert_eq!(m.fields[0].default, Some(Value::Int(5)));
        assert_eq!(m.fields[1].default, Some(Value::Str("a#b".into())));
        assert_eq!(
            m.fields[1].ty.base,
            BaseType::Primitive(Primitive::String(Some(4)))
        );
        assert_eq!(m.constants[0].value, Value::Int(-3));
        assert_eq!(
            m.fields[2].default,
            Some(Value::List(vec![
                Value::Float("1.0".into()),
                Value::Float("2.5".into()),
                Value::Float("-3.0".into())
            ]))
        );
        assert_eq!(m.fields[3].ty.container, Container::BoundedSequence(2));
        assert_eq!(
            m.fields[4].ty.base,
            BaseType::Message(TypeRef {
                package: "std_msgs".into(),
                namespace: "msg".into(),
                name: "Header".into()
            })
        );
    }

    #[test]
    fn errors_name_the_line_and_the_fix() {
        let e = msg("int32 a\nint33 b\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(
            e.to_string()
                .starts_with("pkg/msg/Test.msg:2: unknown type `int33`"),
            "{e}"
        );
        assert!(msg("uint8 x 256")
            .unwrap_err()
            .message
            .contains("out of range 0..=255"));
        assert!(msg("int32 BadName")
            .unwrap_err()
            .message
            .contains("not a valid field name"));
        assert!(msg("int32 a\nint32 a")
            .unwrap_err()
            .message
            .contains("defined twice"));
        assert!(msg("int32[2] a [1]")
            .unwrap_err()
            .message
            .contains("1 values for an array of 2"));
        assert!(msg("string<=2 a \"abc\"")
            .unwrap_err()
            .message
            .contains("longer than the bound"));
        assert!(msg("Other x 3")
            .unwrap_err()
            .message
            .contains("cannot have a default"));
        let e = parse_service("int32 a\n", Path::new("p/srv/S.srv"), "p", "S").unwrap_err();
        assert!(e.message.contains("found 1 sections"), "{e}");
    }

    #[test]
    fn services_and_actions_get_rosidl_types() {
        let s = parse_service(
            "int64 a\n---\nint64 sum\n",
            Path::new("p/srv/Add.srv"),
            "p",
            "Add",
        )
        .unwrap();
        assert_eq!(s.request.ty.full_name(), "p/srv/Add_Request");
        assert_eq!(s.event.ty.full_name(), "p/srv/Add_Event");
        assert_eq!(
            s.event.fields[1].ty.container,
            Container::BoundedSequence(1)
        );
        let a = parse_action(
            "int32 order\n---\nint32[] seq\n---\nint32[] seq\n",
            Path::new("p/action/Fib.action"),
            "p",
            "Fib",
        )
        .unwrap();
        assert_eq!(
            a.send_goal.request.ty.full_name(),
            "p/action/Fib_SendGoal_Request"
        );
        assert_eq!(
            a.get_result.event.ty.full_name(),
            "p/action/Fib_GetResult_Event"
        );
        assert_eq!(a.feedback_message.fields[0].name, "goal_id");
    }
}
