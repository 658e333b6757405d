//! `#[ros(...)]` attributes on the struct and on fields.

use syn::meta::ParseNestedMeta;
use syn::{Attribute, LitStr};

use crate::ctxt::Ctxt;

/// Attributes on the struct.
#[derive(Default)]
pub struct ContainerAttrs {
    /// `type_name = "pkg/msg/Name"`.
    pub type_name: Option<LitStr>,
    /// `package = "pkg"`: the type name becomes `pkg/msg/<struct name>`.
    pub package: Option<LitStr>,
    /// `crate = "path"`: where shm_cdr is reachable from the user's crate.
    pub crate_path: Option<syn::Path>,
    /// `loan`: also generate the `…Lens` / `…Mut` types and `InPlace`, to build
    /// the message in place.
    pub loan: Option<proc_macro2::Span>,
    /// `source = "…"`: the text of the interface file the type comes from (a
    /// string literal or any constant `&'static str` expression).
    pub source: Option<syn::Expr>,
    /// `source_encoding = "msg"`: what that file is (`msg` when only `source` is
    /// given; `implicit` for a type derived from a `.srv` or `.action` file).
    pub source_encoding: Option<LitStr>,
    /// An attribute failed to parse (so a missing name is not reported twice).
    pub malformed: bool,
}

/// How a `u8`/`i8` field is declared in .msg terms.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum OctetKind {
    /// `#[ros(byte)]`: .msg `byte` (IDL `octet`).
    Byte,
    /// `#[ros(char)]`: .msg `char` (IDL `uint8`).
    Char,
}

/// Attributes on a field.
#[derive(Default)]
pub struct FieldAttrs {
    pub octet: Option<(OctetKind, proc_macro2::Span)>,
    pub rename: Option<LitStr>,
    /// `default_value = "…"`: the default the interface file gives the field, as
    /// rosidl writes it in the type description.
    pub default_value: Option<LitStr>,
}

/// What `type_description_interfaces/TypeSource.encoding` holds for rosidl's files.
const SOURCE_ENCODINGS: &[&str] = &["msg", "srv", "action", "idl", "implicit"];

fn set_once<T>(cx: &Ctxt, meta: &ParseNestedMeta, slot: &mut Option<T>, value: T, name: &str) {
    if slot.is_some() {
        cx.error_spanned_by(&meta.path, format!("duplicate `#[ros({name})]`"));
    } else {
        *slot = Some(value);
    }
}

impl ContainerAttrs {
    pub fn from_ast(cx: &Ctxt, attrs: &[Attribute]) -> Self {
        let mut out = Self::default();
        for attr in attrs.iter().filter(|a| a.path().is_ident("ros")) {
            let result = attr.parse_nested_meta(|meta| {
                if meta.path.is_ident("type_name") {
                    let value: LitStr = meta.value()?.parse()?;
                    set_once(cx, &meta, &mut out.type_name, value, "type_name");
                } else if meta.path.is_ident("package") {
                    let value: LitStr = meta.value()?.parse()?;
                    set_once(cx, &meta, &mut out.package, value, "package");
                } else if meta.path.is_ident("crate") {
                    let value: LitStr = meta.value()?.parse()?;
                    match value.parse::<syn::Path>() {
                        Ok(path) => set_once(cx, &meta, &mut out.crate_path, path, "crate"),
                        Err(_) => cx.error_spanned_by(
                            &value,
                            "`crate` must be a path, e.g. `#[ros(crate = \"my_crate::shm_cdr\")]`",
                        ),
                    }
                } else if meta.path.is_ident("loan") {
                    out.loan = Some(syn::spanned::Spanned::span(&meta.path));
                } else if meta.path.is_ident("source") {
                    let value: syn::Expr = meta.value()?.parse()?;
                    set_once(cx, &meta, &mut out.source, value, "source");
                } else if meta.path.is_ident("source_encoding") {
                    let value: LitStr = meta.value()?.parse()?;
                    if !SOURCE_ENCODINGS.contains(&value.value().as_str()) {
                        cx.error_spanned_by(
                            &value,
                            "unknown source encoding: expected \"msg\", \"srv\", \"action\", \"idl\" or \"implicit\"",
                        );
                    }
                    set_once(cx, &meta, &mut out.source_encoding, value, "source_encoding");
                } else if meta.path.is_ident("char")
                    || meta.path.is_ident("byte")
                    || meta.path.is_ident("rename")
                    || meta.path.is_ident("default_value")
                {
                    cx.error_spanned_by(
                        &meta.path,
                        "this is a field attribute: put it on the field, not on the struct",
                    );
                    skip_value(&meta)?;
                } else {
                    cx.error_spanned_by(
                        &meta.path,
                        "unknown struct attribute: expected `type_name = \"pkg/msg/Name\"`, `package = \"pkg\"`, `crate = \"path\"`, `loan`, `source = \"…\"` or `source_encoding = \"msg\"`",
                    );
                    skip_value(&meta)?;
                }
                Ok(())
            });
            if let Err(e) = result {
                out.malformed = true;
                cx.syn_error(e);
            }
        }
        if let (Some(encoding), Some(source)) = (&out.source_encoding, &out.source) {
            if encoding.value() == "implicit" {
                cx.error_spanned_by(
                    source,
                    "an implicit type has no text of its own: remove `source`, or give the file's encoding",
                );
            }
        }
        out
    }
}

impl FieldAttrs {
    pub fn from_ast(cx: &Ctxt, attrs: &[Attribute]) -> Self {
        let mut out = Self::default();
        for attr in attrs.iter().filter(|a| a.path().is_ident("ros")) {
            let result = attr.parse_nested_meta(|meta| {
                let octet = if meta.path.is_ident("byte") {
                    Some(OctetKind::Byte)
                } else if meta.path.is_ident("char") {
                    Some(OctetKind::Char)
                } else {
                    None
                };
                if let Some(kind) = octet {
                    match out.octet {
                        Some((previous, _)) if previous == kind => {
                            cx.error_spanned_by(&meta.path, "duplicate attribute")
                        }
                        Some(_) => cx.error_spanned_by(
                            &meta.path,
                            "a field is either `#[ros(byte)]` or `#[ros(char)]`, not both",
                        ),
                        None => out.octet = Some((kind, meta.path.get_ident().map_or_else(proc_macro2::Span::call_site, syn::Ident::span))),
                    }
                } else if meta.path.is_ident("rename") {
                    let value: LitStr = meta.value()?.parse()?;
                    set_once(cx, &meta, &mut out.rename, value, "rename");
                } else if meta.path.is_ident("default_value") {
                    match meta.value()?.parse::<syn::Lit>()? {
                        syn::Lit::Str(value) => {
                            set_once(cx, &meta, &mut out.default_value, value, "default_value");
                        }
                        other => cx.error_spanned_by(
                            &other,
                            "write the default as rosidl prints it, in quotes: `default_value = \"3\"`, `\"1.0\"`, `\"True\"`, `\"(1, 2)\"`",
                        ),
                    }
                } else if meta.path.is_ident("type_name")
                    || meta.path.is_ident("package")
                    || meta.path.is_ident("crate")
                    || meta.path.is_ident("source")
                    || meta.path.is_ident("source_encoding")
                {
                    cx.error_spanned_by(
                        &meta.path,
                        "this is a struct attribute: put it on the struct, not on a field",
                    );
                    skip_value(&meta)?;
                } else {
                    cx.error_spanned_by(
                        &meta.path,
                        "unknown field attribute: expected `byte`, `char`, `rename = \"ros_name\"` or `default_value = \"…\"`",
                    );
                    skip_value(&meta)?;
                }
                Ok(())
            });
            if let Err(e) = result {
                cx.syn_error(e);
            }
        }
        out
    }
}

/// Consume `= value` after an unknown key so parsing continues to the next key.
fn skip_value(meta: &ParseNestedMeta) -> syn::Result<()> {
    if meta.input.peek(syn::Token![=]) {
        let _: syn::Expr = meta.value()?.parse()?;
    }
    Ok(())
}
