//! The JSON text rosidl hashes (`calculate_type_hash`) and installs: a type's
//! description and those of the types it references, separators `", "` and
//! `": "`; and the `RIHS01` hash of it.

use std::fmt::Write as _;

use sha2::{Digest, Sha256};

use crate::described::DescribedField;

/// A full type description's JSON as rosidl writes it: the first of `types`
/// is the type, the others the types it references, each as its name and
/// fields (for the hash, the referenced types sorted by name and no
/// `defaults`; with `defaults`, as rosidl installs it in its `.json` files).
pub fn description_json<'a, F>(
    types: impl IntoIterator<Item = (&'a str, F)>,
    defaults: bool,
) -> String
where
    F: IntoIterator<Item = DescribedField<'a>>,
{
    let mut types = types.into_iter();
    let mut out = String::with_capacity(1024);
    out.push_str("{\"type_description\": ");
    if let Some((type_name, fields)) = types.next() {
        write_individual_json(&mut out, type_name, fields.into_iter(), defaults);
    }
    out.push_str(", \"referenced_type_descriptions\": [");
    for (i, (type_name, fields)) in types.enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        write_individual_json(&mut out, type_name, fields.into_iter(), defaults);
    }
    out.push_str("]}");
    out
}

/// One `IndividualTypeDescription` as rosidl writes it for the hash (or, with
/// `defaults`, with default values).
pub fn write_individual_json<'a>(
    out: &mut String,
    type_name: &str,
    fields: impl Iterator<Item = DescribedField<'a>>,
    defaults: bool,
) {
    out.push_str("{\"type_name\": ");
    write_json_string(out, type_name);
    out.push_str(", \"fields\": [");
    for (i, field) in fields.enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str("{\"name\": ");
        write_json_string(out, field.name);
        let _ = write!(
            out,
            ", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": {}, \"nested_type_name\": ",
            field.type_id, field.capacity, field.string_capacity,
        );
        write_json_string(out, field.nested_type_name);
        out.push('}');
        if defaults {
            out.push_str(", \"default_value\": ");
            write_json_string(out, field.default_value);
        }
        out.push('}');
    }
    out.push_str("]}");
}

fn write_json_string(out: &mut String, text: &str) {
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if u32::from(c) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// `RIHS01_` followed by the lowercase hex SHA-256 of `json`.
pub fn rihs01_of_json(json: &str) -> String {
    let digest = Sha256::digest(json.as_bytes());
    let mut out = String::with_capacity(7 + 64);
    out.push_str("RIHS01_");
    for byte in digest {
        let _ = write!(out, "{byte:02x}");
    }
    out
}
