//! The JSON text rosidl hashes (`calculate_type_hash`) and installs: a type's
//! description and those of the types it references, separators `", "` and
//! `": "`; and the `RIHS01` hash of it.

use std::fmt::Write as _;

use sha2::{Digest, Sha256};

use crate::description::{DescribedField, TypeDescription};

fn write_type_description(out: &mut String, description: &TypeDescription, defaults: bool) {
    write_individual_json(
        out,
        description.type_name,
        description.fields.iter().map(DescribedField::of),
        defaults,
    );
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

/// The exact text rosidl hashes for a type: its description and the descriptions of
/// the types it references.
pub fn type_description_json<'a>(
    description: &TypeDescription,
    referenced: impl IntoIterator<Item = &'a TypeDescription>,
) -> String {
    description_json(description, referenced, false)
}

pub(crate) fn description_json<'a>(
    description: &TypeDescription,
    referenced: impl IntoIterator<Item = &'a TypeDescription>,
    defaults: bool,
) -> String {
    let mut out = String::with_capacity(1024);
    out.push_str("{\"type_description\": ");
    write_type_description(&mut out, description, defaults);
    out.push_str(", \"referenced_type_descriptions\": [");
    for (i, referenced) in referenced.into_iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        write_type_description(&mut out, referenced, defaults);
    }
    out.push_str("]}");
    out
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
