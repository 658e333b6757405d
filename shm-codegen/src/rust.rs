//! Rust source from the parsed interfaces: one module per package with `msg`,
//! `srv` and `action` submodules; structs with `#[derive(RosMessage)]`, their
//! constants and defaults, a borrowing `…Ref<'a>` form where one helps, and the
//! `RosService`/`RosAction` identities.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;

use crate::ast::{
    Action, BaseType, Container, Field, FieldType, Message, Package, Primitive, Service, TypeRef,
    Value,
};

/// How the generated code refers to the outside world.
#[derive(Debug, Clone)]
pub struct Options {
    /// Path of the shm-cdr crate from the generated code (`::shm_cdr`, or `crate`
    /// inside shm-cdr).
    pub crate_path: String,
    /// Where packages not generated in the same run live: a reference to
    /// `pkg/msg/Name` becomes `<extern_root>::pkg::msg::Name`.
    pub extern_root: String,
    /// Add `#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]` to
    /// owned forms (the generating crate must have that feature).
    pub arbitrary: bool,
    /// Generate the borrowing `…Ref<'a>` forms (and `BorrowedForm` impls).
    pub borrowed: bool,
    /// Also generate a `<Name>Shm` form of every message with unbounded
    /// `uint8[]`/`byte[]` fields of its own, those fields typed as this path
    /// (e.g. `::shm_runtime::ShmBytes`: bytes the application wrote into shared
    /// memory, published without a copy). The type must encode and decode as a
    /// `uint8[]` and convert `From<Vec<u8>>`.
    pub shm_bytes: Option<String>,
    /// Generate only the `…Shm` forms, every other type referenced under
    /// `extern_root` (how shm-runtime gets its forms of the standard set).
    pub shm_forms_only: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            crate_path: "::shm_cdr".into(),
            extern_root: "::shm_cdr::msgs".into(),
            arbitrary: false,
            borrowed: true,
            shm_bytes: None,
            shm_forms_only: false,
        }
    }
}

/// Owned struct, the form that borrows strings and byte sequences, or the form
/// whose byte sequences are shared-memory buffers.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Form {
    Owned,
    Borrowed,
    Shm,
}

/// What the generator knows about every message type of the run.
struct Index<'a> {
    messages: HashMap<String, &'a Message>,
    packages: Vec<&'a str>,
    options: &'a Options,
    memo: std::cell::RefCell<HashMap<(String, u8), bool>>,
}

#[derive(Clone, Copy)]
enum Property {
    /// Every field is `Copy` (no strings or sequences).
    Copy,
    /// No floats anywhere, so `Eq` and `Hash` can be derived.
    Eq,
    /// Some string or byte sequence that the `Ref` form borrows.
    Borrows,
    /// Only numbers and fixed arrays of them: `#[repr(C)]` lets sequences of it
    /// be copied in bulk.
    Plain,
}

impl<'a> Index<'a> {
    fn new(packages: &'a [Package], options: &'a Options) -> Self {
        let messages = packages
            .iter()
            .flat_map(|p| p.all_messages())
            .map(|m| (m.ty.full_name(), m))
            .collect();
        Self {
            messages,
            packages: packages.iter().map(|p| p.name.as_str()).collect(),
            options,
            memo: Default::default(),
        }
    }

    /// Whether message `r` has `property`. Of external types only what holds for
    /// any message is assumed: they may borrow (their `BorrowedForm` says how),
    /// and are not assumed `Copy`, `Eq` or plain, which only costs a derive.
    fn has(&self, r: &TypeRef, property: Property) -> bool {
        let key = (r.full_name(), property as u8);
        if let Some(&known) = self.memo.borrow().get(&key) {
            return known;
        }
        // ROS types cannot be recursive; the provisional `false` ends any cycle.
        self.memo.borrow_mut().insert(key.clone(), false);
        let value = match self.messages.get(&key.0) {
            Some(m) => match property {
                Property::Copy | Property::Plain => {
                    !m.fields.is_empty() && m.fields.iter().all(|f| self.field_has(f, property))
                }
                Property::Eq => m.fields.iter().all(|f| self.field_has(f, property)),
                Property::Borrows => m.fields.iter().any(|f| self.field_has(f, property)),
            },
            None => matches!(property, Property::Borrows),
        };
        self.memo.borrow_mut().insert(key, value);
        value
    }

    fn field_has(&self, f: &Field, property: Property) -> bool {
        let fixed = matches!(f.ty.container, Container::Single | Container::Array(_));
        match (&f.ty.base, property) {
            (BaseType::Primitive(p), Property::Copy) => fixed && !p.is_string(),
            (BaseType::Primitive(p), Property::Plain) => {
                fixed && !p.is_string() && *p != Primitive::Bool
            }
            (BaseType::Primitive(p), Property::Eq) => !p.is_float(),
            (BaseType::Primitive(p), Property::Borrows) => match p {
                Primitive::String(None) => true,
                // Byte sequences borrow as they are; other number sequences when
                // they lie aligned (always, in a shm-runtime payload).
                _ if p.is_string() || *p == Primitive::Bool => false,
                _ => f.ty.container == Container::Sequence,
            },
            (BaseType::Message(r), Property::Borrows) => {
                self.has(r, property)
                    || (f.ty.container == Container::Sequence && self.has(r, Property::Plain))
            }
            (BaseType::Message(r), Property::Copy | Property::Plain) => {
                fixed && self.has(r, property)
            }
            (BaseType::Message(r), _) => self.has(r, property),
        }
    }

    /// Whether `r` is generated in this run, as opposed to referenced under
    /// `extern_root`.
    fn is_local(&self, r: &TypeRef) -> bool {
        !self.options.shm_forms_only && self.packages.contains(&r.package.as_str())
    }

    /// The Rust path of message `r` (in its owned form) seen from module `from`.
    fn owned_path(&self, r: &TypeRef, from: &TypeRef) -> String {
        if !self.is_local(r) {
            format!(
                "{}::{}::{}::{}",
                self.options.extern_root, r.package, r.namespace, r.name
            )
        } else if r.package == from.package && r.namespace == from.namespace {
            r.name.clone()
        } else {
            format!("super::super::{}::{}::{}", r.package, r.namespace, r.name)
        }
    }

    /// The Rust type of a field of message type `r` in `form`, seen from `from`.
    /// Nested messages keep their owned form inside a `…Shm` form.
    fn path(&self, r: &TypeRef, from: &TypeRef, form: Form) -> String {
        let owned = self.owned_path(r, from);
        match form {
            Form::Borrowed if !self.is_local(r) => format!(
                "<{owned} as {}::BorrowedForm>::Ref<'a>",
                self.options.crate_path
            ),
            Form::Borrowed if self.has(r, Property::Borrows) => format!("{owned}Ref<'a>"),
            _ => owned,
        }
    }

    /// Whether message `m` gets a `…Shm` form.
    fn has_shm_form(&self, m: &Message) -> bool {
        self.options.shm_bytes.is_some() && m.fields.iter().any(is_byte_sequence)
    }
}

/// The generated source of one package.
pub struct PackageSource {
    /// The package name (the module's name).
    pub name: String,
    /// One line describing the package, for its module documentation.
    pub summary: String,
    /// The module's items: `msg`, `srv` and `action` submodules and a re-export of
    /// the messages.
    pub body: String,
}

/// The message types that get a borrowing `…Ref<'a>` form.
pub fn borrowing_types(packages: &[Package]) -> Vec<TypeRef> {
    let options = Options::default();
    let index = Index::new(packages, &options);
    packages
        .iter()
        .flat_map(|p| p.all_messages())
        .filter(|m| index.has(&m.ty, Property::Borrows))
        .map(|m| m.ty.clone())
        .collect()
}

/// Generate the Rust source of each package, in the order given.
pub fn generate(packages: &[Package], options: &Options) -> Vec<PackageSource> {
    let index = Index::new(packages, options);
    packages.iter().map(|p| package_source(&index, p)).collect()
}

fn package_source(index: &Index, package: &Package) -> PackageSource {
    if index.options.shm_forms_only {
        return shm_forms_source(index, package);
    }
    let mut out = String::new();
    let mut modules: BTreeMap<&str, String> = BTreeMap::new();
    for m in &package.messages {
        message_items(
            index,
            m,
            &format!("msg/{}.msg", m.ty.name),
            modules.entry("msg").or_default(),
        );
    }
    for s in &package.services {
        service_items(
            index,
            s,
            &format!("srv/{}.srv", s.ty.name),
            modules.entry("srv").or_default(),
        );
    }
    for a in &package.actions {
        action_items(index, a, modules.entry("action").or_default());
    }
    let counts = format!(
        "{}, {}, {}",
        count(package.messages.len(), "message"),
        count(package.services.len(), "service"),
        count(package.actions.len(), "action")
    );
    let summary = format!("`{}`: {counts}.", package.name);
    for (name, body) in &modules {
        let what = match *name {
            "msg" => "Messages (`msg/*.msg`).",
            "srv" => "Services (`srv/*.srv`): each one's request, response and event messages and its [`RosService`](CRATE::RosService) identity.",
            _ => "Actions (`action/*.action`): goal, result and feedback, the services and message built from them, and the [`RosAction`](CRATE::RosAction) identity.",
        };
        let what = what.replace("CRATE", &index.options.crate_path);
        let _ = writeln!(
            out,
            "\n/// {what}\n#[allow(non_camel_case_types, dead_code, clippy::all)]\npub mod {name} {{"
        );
        out.push_str(body);
        out.push_str("}\n");
    }
    if modules.contains_key("msg") {
        let _ = writeln!(
            out,
            "\n#[doc(no_inline)]\n#[allow(unused_imports)]\npub use msg::*;"
        );
    }
    PackageSource {
        name: package.name.clone(),
        summary,
        body: out.trim_start().to_owned(),
    }
}

/// Only the `…Shm` forms of a package's messages, in a module per namespace;
/// `body` is empty when the package has none.
fn shm_forms_source(index: &Index, package: &Package) -> PackageSource {
    let mut modules: BTreeMap<&str, Vec<&Message>> = BTreeMap::new();
    for m in package.all_messages().filter(|m| index.has_shm_form(m)) {
        modules.entry(m.ty.namespace.as_str()).or_default().push(m);
    }
    let mut out = String::new();
    let mut names = Vec::new();
    for (namespace, messages) in &modules {
        let _ = writeln!(
            out,
            "\n/// `{}/{namespace}` types with byte sequences of their own, in their `…Shm` form.\n#[allow(non_camel_case_types, clippy::all)]\npub mod {namespace} {{",
            package.name
        );
        for m in messages {
            // `Name_Request` comes from `srv/Name.srv` (type names have no `_`).
            let base = m.ty.name.split('_').next().unwrap_or(&m.ty.name);
            let file = format!("{namespace}/{base}.{namespace}");
            write_struct(index, m, &file, Form::Shm, &mut out);
            names.push(format!("`{}Shm`", m.ty.name));
        }
        out.push_str("}\n");
    }
    if modules.contains_key("msg") {
        let _ = writeln!(
            out,
            "\n#[doc(no_inline)]\n#[allow(unused_imports)]\npub use msg::*;"
        );
    }
    PackageSource {
        name: package.name.clone(),
        summary: format!("`{}`: {}.", package.name, names.join(", ")),
        body: out.trim_start().to_owned(),
    }
}

fn service_items(index: &Index, s: &Service, file: &str, out: &mut String) {
    for m in [&s.request, &s.response, &s.event] {
        message_items(index, m, file, out);
    }
    let krate = &index.options.crate_path;
    let mut doc = s.doc.clone();
    if !doc.is_empty() {
        doc.push(String::new());
    }
    write_doc(
        out,
        &doc,
        &format!("The service `{}` (from `{file}`).", s.ty.full_name()),
    );
    let name = &s.ty.name;
    let _ = write!(
        out,
        "#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct {name};

impl {krate}::RosService for {name} {{
    const TYPE_NAME: &'static str = \"{full}\";
    const DDS_TYPE_NAME: &'static str = \"{dds}\";
    type Request = {name}_Request;
    type Response = {name}_Response;
    type Event = {name}_Event;
    const SOURCE: {krate}::describe::TypeSource = {source};

    fn type_hash() -> &'static str {{
        static HASH: ::std::sync::OnceLock<::std::string::String> = ::std::sync::OnceLock::new();
        HASH.get_or_init({krate}::interface::compute_service_hash::<Self>)
    }}
}}

",
        full = s.ty.full_name(),
        dds = dds_name(&s.ty),
        source = type_source(krate, "srv", s.source.as_deref()),
    );
}

fn action_items(index: &Index, a: &Action, out: &mut String) {
    let file = format!("action/{}.action", a.ty.name);
    for m in [&a.goal, &a.result, &a.feedback] {
        message_items(index, m, &file, out);
    }
    service_items(index, &a.send_goal, &file, out);
    service_items(index, &a.get_result, &file, out);
    message_items(index, &a.feedback_message, &file, out);
    let krate = &index.options.crate_path;
    let mut doc = a.doc.clone();
    if !doc.is_empty() {
        doc.push(String::new());
    }
    write_doc(
        out,
        &doc,
        &format!("The action `{}` (from `{file}`).", a.ty.full_name()),
    );
    let name = &a.ty.name;
    let _ = write!(
        out,
        "#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct {name};

impl {krate}::RosAction for {name} {{
    const TYPE_NAME: &'static str = \"{full}\";
    const DDS_TYPE_NAME: &'static str = \"{dds}\";
    type Goal = {name}_Goal;
    type Result = {name}_Result;
    type Feedback = {name}_Feedback;
    type SendGoal = {name}_SendGoal;
    type GetResult = {name}_GetResult;
    type FeedbackMessage = {name}_FeedbackMessage;
    const SOURCE: {krate}::describe::TypeSource = {source};

    fn send_goal_request(goal_id: {krate}::interface::GoalId, goal: {name}_Goal) -> {name}_SendGoal_Request {{
        let mut request = {name}_SendGoal_Request {{ goal_id: ::core::default::Default::default(), goal }};
        request.goal_id.uuid = goal_id;
        request
    }}

    fn send_goal_request_parts(request: {name}_SendGoal_Request) -> ({krate}::interface::GoalId, {name}_Goal) {{
        (request.goal_id.uuid, request.goal)
    }}

    fn send_goal_response(accepted: bool, stamp: {krate}::interface::Stamp) -> {name}_SendGoal_Response {{
        let mut response = {name}_SendGoal_Response {{ accepted, stamp: ::core::default::Default::default() }};
        response.stamp.sec = stamp.sec;
        response.stamp.nanosec = stamp.nanosec;
        response
    }}

    fn send_goal_response_parts(response: &{name}_SendGoal_Response) -> (bool, {krate}::interface::Stamp) {{
        (response.accepted, {krate}::interface::Stamp {{ sec: response.stamp.sec, nanosec: response.stamp.nanosec }})
    }}

    fn get_result_request(goal_id: {krate}::interface::GoalId) -> {name}_GetResult_Request {{
        let mut request = {name}_GetResult_Request::default();
        request.goal_id.uuid = goal_id;
        request
    }}

    fn get_result_request_goal_id(request: &{name}_GetResult_Request) -> {krate}::interface::GoalId {{
        request.goal_id.uuid
    }}

    fn get_result_response(status: i8, result: {name}_Result) -> {name}_GetResult_Response {{
        {name}_GetResult_Response {{ status, result }}
    }}

    fn get_result_response_parts(response: {name}_GetResult_Response) -> (i8, {name}_Result) {{
        (response.status, response.result)
    }}

    fn feedback_message(goal_id: {krate}::interface::GoalId, feedback: {name}_Feedback) -> {name}_FeedbackMessage {{
        let mut message = {name}_FeedbackMessage {{ goal_id: ::core::default::Default::default(), feedback }};
        message.goal_id.uuid = goal_id;
        message
    }}

    fn feedback_message_parts(message: {name}_FeedbackMessage) -> ({krate}::interface::GoalId, {name}_Feedback) {{
        (message.goal_id.uuid, message.feedback)
    }}

    fn type_hash() -> &'static str {{
        static HASH: ::std::sync::OnceLock<::std::string::String> = ::std::sync::OnceLock::new();
        HASH.get_or_init({krate}::interface::compute_action_hash::<Self>)
    }}
}}

",
        full = a.ty.full_name(),
        dds = dds_name(&a.ty),
        source = type_source(krate, "action", a.source.as_deref()),
    );
}

/// The `TypeSource` constant of a service or action: its file, or implicit (an
/// action's `SendGoal` and `GetResult`).
fn type_source(krate: &str, encoding: &str, text: Option<&str>) -> String {
    match text {
        Some(text) => format!("{krate}::describe::TypeSource::file({encoding:?}, {text:?})"),
        None => format!("{krate}::describe::TypeSource::IMPLICIT"),
    }
}

fn dds_name(r: &TypeRef) -> String {
    format!("{}::{}::dds_::{}_", r.package, r.namespace, r.name)
}

fn message_items(index: &Index, m: &Message, file: &str, out: &mut String) {
    write_struct(index, m, file, Form::Owned, out);
    if index.options.borrowed {
        let borrows = index.has(&m.ty, Property::Borrows);
        if borrows {
            write_struct(index, m, file, Form::Borrowed, out);
        }
        let (name, reference) = if borrows {
            (&m.ty.name, format!("{}Ref<'a>", m.ty.name))
        } else {
            (&m.ty.name, "Self".to_owned())
        };
        let _ = writeln!(
            out,
            "impl {}::BorrowedForm for {name} {{\n    type Ref<'a> = {reference};\n}}\n",
            index.options.crate_path
        );
    }
    if index.has_shm_form(m) {
        write_struct(index, m, file, Form::Shm, out);
    }
}

fn write_struct(index: &Index, m: &Message, file: &str, form: Form, out: &mut String) {
    let krate = &index.options.crate_path;
    let (name, generics) = match form {
        Form::Owned => (m.ty.name.clone(), ""),
        Form::Borrowed => (format!("{}Ref", m.ty.name), "<'a>"),
        Form::Shm => (format!("{}Shm", m.ty.name), ""),
    };
    let owned = index.owned_path(&m.ty, &m.ty);
    let mut doc = m.doc.clone();
    if !doc.is_empty() {
        doc.push(String::new());
    }
    let tail = match form {
        Form::Owned => format!("`{}` (from `{file}`).", m.ty.full_name()),
        Form::Borrowed => format!(
            "[`{}`] borrowing its strings and byte sequences from the input it is decoded from: same type, same bytes, same hash.",
            m.ty.name
        ),
        Form::Shm => format!(
            "[`{}`]({owned}) with its own byte sequences as [`{}`]({}), which a publisher splices into the message without a copy when they sit in shared memory: same type, same bytes, same hash. `From<{}>` moves the fields over.",
            m.ty.name,
            shm_bytes_name(index),
            shm_bytes_type(index),
            m.ty.name,
        ),
    };
    write_doc(out, &doc, &tail);

    let mut derives = vec![
        format!("{krate}::RosMessage"),
        "Debug".into(),
        "Clone".into(),
        "PartialEq".into(),
    ];
    if form == Form::Owned && index.has(&m.ty, Property::Copy) {
        derives.push("Copy".into());
    }
    if form == Form::Owned && index.has(&m.ty, Property::Eq) {
        derives.extend(["Eq".into(), "Hash".into()]);
    }
    let _ = writeln!(out, "#[derive({})]", derives.join(", "));
    if form == Form::Owned && index.options.arbitrary {
        out.push_str("#[cfg_attr(feature = \"arbitrary\", derive(arbitrary::Arbitrary))]\n");
    }
    // Owned forms can be built in place (loans); borrowing forms are read only.
    let loan = if form == Form::Borrowed { "" } else { ", loan" };
    // The file's text is written once, on the owned form; the other forms name it.
    let source = match (&m.source, form) {
        (None, _) => ", source_encoding = \"implicit\"".to_owned(),
        (Some(text), Form::Owned) => format!(", source = {text:?}"),
        (Some(_), _) => {
            format!(", source = <{owned} as {krate}::RosMessage>::SOURCE.raw_file_contents")
        }
    };
    let _ = writeln!(
        out,
        "#[ros(type_name = \"{}\", crate = \"{krate}\"{loan}{source})]",
        m.ty.full_name()
    );
    if index.has(&m.ty, Property::Plain) {
        out.push_str("#[repr(C)]\n");
    }
    if m.fields.is_empty() {
        let _ = writeln!(out, "pub struct {name}{generics};\n");
    } else {
        let _ = writeln!(out, "pub struct {name}{generics} {{");
        for f in &m.fields {
            if f.doc.is_empty() {
                // No comment in the file: say what the field is in .msg terms.
                let _ = writeln!(out, "    /// `{} {}`", f.ty, f.name);
            }
            write_doc_indented(out, &f.doc, "    ");
            match &f.ty.base {
                BaseType::Primitive(Primitive::Byte) => out.push_str("    #[ros(byte)]\n"),
                BaseType::Primitive(Primitive::Char) => out.push_str("    #[ros(char)]\n"),
                _ => {}
            }
            let (ident, rename) = rust_ident(&f.name);
            if let Some(rename) = rename {
                let _ = writeln!(out, "    #[ros(rename = \"{rename}\")]");
            }
            if let Some(default) = &f.default {
                let _ = writeln!(
                    out,
                    "    #[ros(default_value = {:?})]",
                    default.description_default()
                );
            }
            let _ = writeln!(
                out,
                "    pub {ident}: {},",
                field_type(index, &f.ty, &m.ty, form)
            );
        }
        out.push_str("}\n\n");
    }

    if form == Form::Shm {
        let _ = writeln!(
            out,
            "impl ::core::convert::From<{owned}> for {name} {{\n    fn from(message: {owned}) -> Self {{\n        Self {{"
        );
        for f in &m.fields {
            let (ident, _) = rust_ident(&f.name);
            if is_byte_sequence(f) {
                let _ = writeln!(
                    out,
                    "            {ident}: ::core::convert::From::from(message.{ident}),"
                );
            } else {
                let _ = writeln!(out, "            {ident}: message.{ident},");
            }
        }
        out.push_str("        }\n    }\n}\n\n");
    }

    // Constants, on the owned form only.
    if form == Form::Owned && !m.constants.is_empty() {
        let _ = writeln!(out, "impl {name} {{");
        for c in &m.constants {
            if c.doc.is_empty() {
                let _ = writeln!(out, "    /// `{}`", c.name);
            }
            write_doc_indented(out, &c.doc, "    ");
            let ty = match c.ty {
                Primitive::String(_) | Primitive::WString(_) => "&'static str".to_owned(),
                p => primitive_type(p, krate),
            };
            let _ = writeln!(
                out,
                "    pub const {}: {ty} = {};",
                c.name,
                const_literal(&c.value, c.ty)
            );
        }
        out.push_str("}\n\n");
    }

    // Default: zeros, empty strings and sequences, and the .msg default values.
    let _ = writeln!(out, "impl{generics} ::core::default::Default for {name}{generics} {{\n    fn default() -> Self {{");
    if m.fields.is_empty() {
        out.push_str("        Self {}\n");
    } else {
        out.push_str("        Self {\n");
        for f in &m.fields {
            let (ident, _) = rust_ident(&f.name);
            let _ = writeln!(
                out,
                "            {ident}: {},",
                default_expr(f, form, krate)
            );
        }
        out.push_str("        }\n");
    }
    out.push_str("    }\n}\n\n");
}

/// A field name as a Rust identifier, with the ROS name when it differs.
fn rust_ident(name: &str) -> (String, Option<&str>) {
    const RAW: &[&str] = &[
        "as", "async", "await", "break", "const", "continue", "dyn", "else", "enum", "extern",
        "false", "fn", "for", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut",
        "pub", "ref", "return", "static", "struct", "trait", "true", "type", "unsafe", "use",
        "where", "while", "abstract", "become", "box", "do", "final", "gen", "macro", "override",
        "priv", "try", "typeof", "unsized", "virtual", "yield",
    ];
    match name {
        "self" | "super" | "crate" => (format!("{name}_"), Some(name)),
        _ if RAW.contains(&name) => (format!("r#{name}"), None),
        _ => (name.to_owned(), None),
    }
}

fn primitive_type(p: Primitive, krate: &str) -> String {
    match p {
        Primitive::Bool => "bool".into(),
        Primitive::Byte | Primitive::Char | Primitive::UInt8 => "u8".into(),
        Primitive::Int8 => "i8".into(),
        Primitive::Int16 => "i16".into(),
        Primitive::UInt16 => "u16".into(),
        Primitive::Int32 => "i32".into(),
        Primitive::UInt32 => "u32".into(),
        Primitive::Int64 => "i64".into(),
        Primitive::UInt64 => "u64".into(),
        Primitive::Float32 => "f32".into(),
        Primitive::Float64 => "f64".into(),
        Primitive::String(None) => "::std::string::String".into(),
        Primitive::String(Some(n)) => format!("{krate}::BoundedString<{n}>"),
        Primitive::WString(None) => format!("{krate}::WString"),
        Primitive::WString(Some(n)) => format!("{krate}::BoundedWString<{n}>"),
    }
}

fn is_octet(p: Primitive) -> bool {
    matches!(p, Primitive::Byte | Primitive::Char | Primitive::UInt8)
}

/// An unbounded `uint8[]`, `byte[]` or `char[]` field: what the `…Shm` form
/// holds in a shared-memory buffer.
fn is_byte_sequence(f: &Field) -> bool {
    matches!(f.ty.base, BaseType::Primitive(p) if is_octet(p))
        && f.ty.container == Container::Sequence
}

fn shm_bytes_type<'a>(index: &Index<'a>) -> &'a str {
    index.options.shm_bytes.as_deref().unwrap_or_default()
}

fn shm_bytes_name<'a>(index: &Index<'a>) -> &'a str {
    let ty = shm_bytes_type(index);
    ty.rsplit("::").next().unwrap_or(ty)
}

fn field_type(index: &Index, ty: &FieldType, from: &TypeRef, form: Form) -> String {
    let krate = &index.options.crate_path;
    if form == Form::Shm
        && matches!(ty.base, BaseType::Primitive(p) if is_octet(p))
        && ty.container == Container::Sequence
    {
        return shm_bytes_type(index).to_owned();
    }
    let element = match (&ty.base, form) {
        // Not `&'a str`: from shared memory, which another process may rewrite
        // after the UTF-8 check, a string is copied (`Cow::Owned`).
        (BaseType::Primitive(Primitive::String(None)), Form::Borrowed) => {
            "::std::borrow::Cow<'a, str>".to_owned()
        }
        (BaseType::Primitive(p), _) => primitive_type(*p, krate),
        (BaseType::Message(r), _) => index.path(r, from, form),
    };
    match ty.container {
        Container::Single => element,
        Container::Array(n) => format!("[{element}; {n}]"),
        Container::BoundedSequence(n) => format!("{krate}::BoundedVec<{element}, {n}>"),
        Container::Sequence => match (&ty.base, form) {
            (BaseType::Primitive(p), Form::Borrowed) if is_octet(*p) => "&'a [u8]".into(),
            // Numbers and plain messages: borrowed in O(1) where aligned.
            (BaseType::Primitive(p), Form::Borrowed) if !p.is_string() && *p != Primitive::Bool => {
                format!("::std::borrow::Cow<'a, [{element}]>")
            }
            (BaseType::Message(r), Form::Borrowed) if index.has(r, Property::Plain) => {
                format!("::std::borrow::Cow<'a, [{element}]>")
            }
            _ => format!("::std::vec::Vec<{element}>"),
        },
    }
}

fn default_expr(f: &Field, form: Form, krate: &str) -> String {
    let Some(value) = &f.default else {
        return match f.ty.container {
            // `Default` for arrays stops at 32 elements; `from_fn` has no limit.
            Container::Array(_) => {
                "::core::array::from_fn(|_| ::core::default::Default::default())".into()
            }
            _ => "::core::default::Default::default()".into(),
        };
    };
    let BaseType::Primitive(p) = f.ty.base else {
        return "::core::default::Default::default()".into();
    };
    let borrowed_str = form == Form::Borrowed && p == Primitive::String(None);
    let scalar = |v: &Value| match v {
        Value::Str(s) if borrowed_str => format!("::std::borrow::Cow::Borrowed({s:?})"),
        Value::Str(s) => format!("::core::convert::From::from({s:?})"),
        other => const_literal(other, p),
    };
    match (value, f.ty.container) {
        (Value::List(items), Container::Array(_)) => {
            format!(
                "[{}]",
                items.iter().map(scalar).collect::<Vec<_>>().join(", ")
            )
        }
        (Value::List(items), Container::Sequence) if form == Form::Shm && is_octet(p) => {
            format!(
                "::core::convert::From::from(::std::vec![{}])",
                items.iter().map(scalar).collect::<Vec<_>>().join(", ")
            )
        }
        (Value::List(items), Container::Sequence) if form == Form::Borrowed && is_octet(p) => {
            format!(
                "&[{}]",
                items.iter().map(scalar).collect::<Vec<_>>().join(", ")
            )
        }
        (Value::List(items), Container::Sequence)
            if form == Form::Borrowed && !p.is_string() && p != Primitive::Bool =>
        {
            format!(
                "::std::borrow::Cow::Owned(::std::vec![{}])",
                items.iter().map(scalar).collect::<Vec<_>>().join(", ")
            )
        }
        (Value::List(items), Container::Sequence) => {
            format!(
                "::std::vec![{}]",
                items.iter().map(scalar).collect::<Vec<_>>().join(", ")
            )
        }
        (Value::List(items), Container::BoundedSequence(_)) => format!(
            "{krate}::BoundedVec::from(::std::vec![{}])",
            items.iter().map(scalar).collect::<Vec<_>>().join(", ")
        ),
        (v, _) => scalar(v),
    }
}

/// A constant or scalar default as a Rust literal of type `p`.
fn const_literal(value: &Value, p: Primitive) -> String {
    match value {
        Value::Bool(b) => b.to_string(),
        Value::Int(i) if p.is_float() => format!("{i}.0"),
        Value::Int(i) => i.to_string(),
        Value::Float(f) => f.clone(),
        Value::Str(s) => format!("{s:?}"),
        Value::List(_) => "::core::default::Default::default()".into(),
    }
}

fn write_doc(out: &mut String, doc: &[String], tail: &str) {
    for line in doc {
        write_doc_line(out, "", line);
    }
    write_doc_line_raw(out, "", tail);
}

fn write_doc_indented(out: &mut String, doc: &[String], indent: &str) {
    for line in doc {
        write_doc_line(out, indent, line);
    }
}

fn write_doc_line_raw(out: &mut String, indent: &str, text: &str) {
    if text.is_empty() {
        let _ = writeln!(out, "{indent}///");
    } else {
        let _ = writeln!(out, "{indent}/// {text}");
    }
}

/// A comment line from an interface file as rustdoc text: Markdown that would
/// change its meaning (links, HTML, headings, indented code that would become a
/// doctest) is escaped, and bare URLs are made links.
fn write_doc_line(out: &mut String, indent: &str, line: &str) {
    let mut text = String::new();
    let mut rest = line.trim();
    while !rest.is_empty() {
        let at = ["https://", "http://"]
            .iter()
            .filter_map(|p| rest.find(p))
            .min();
        let (plain, url, after) = match at {
            Some(start) => {
                let tail = &rest[start..];
                let end = tail
                    .find(|c: char| {
                        c.is_whitespace()
                            || matches!(c, '"' | '\'' | '<' | '>' | '[' | ']' | '(' | ')')
                    })
                    .unwrap_or(tail.len());
                let url = tail[..end].trim_end_matches(['.', ',', ';', ':']);
                (&rest[..start], url, &tail[url.len()..])
            }
            None => (rest, "", ""),
        };
        for c in plain.chars() {
            let line_start = text.trim().is_empty();
            if matches!(c, '[' | ']' | '<' | '>' | '*' | '\\')
                || (line_start && matches!(c, '#' | '=' | '-' | '+'))
            {
                text.push('\\');
            }
            text.push(c);
        }
        if !url.is_empty() {
            let _ = write!(text, "<{url}>");
        }
        rest = after;
    }
    write_doc_line_raw(out, indent, &text);
}

/// `n` things, in English: "1 message", "2 messages".
pub fn count(n: usize, thing: &str) -> String {
    match n {
        1 => format!("1 {thing}"),
        n => format!("{n} {thing}s"),
    }
}

/// The body of a table of the interface files other distributions word
/// differently, as `(distro, type name, text)` rows in the order given:
/// `pub(crate) const SOURCES: &[(&str, &str, &str)]`.
pub fn distro_sources(rows: &[(String, crate::ast::RewordedSource)]) -> String {
    let mut out = String::from(
        "/// `(distribution, pkg/kind/Name, the file's text)`.\npub(crate) const SOURCES: &[(&str, &str, &str)] = &[\n",
    );
    for (distro, source) in rows {
        out.push_str(&format!(
            "    ({distro:?}, {:?}, {:?}),\n",
            source.type_name, source.text
        ));
    }
    out.push_str("];\n");
    out
}
