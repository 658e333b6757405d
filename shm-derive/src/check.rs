//! Validation of the IR: names ROS accepts, no type generics, and the field types
//! that are recognizably wrong, each with what to write instead. Anything subtler
//! is caught by the trait bounds in the generated code, at the field's span.

use syn::{GenericArgument, GenericParam, PathArguments, Type};

use crate::ast::Container;
use crate::ctxt::Ctxt;

pub fn check(cx: &Ctxt, container: &Container) {
    check_generics(cx, container);
    if let (Some(span), false) = (container.attrs.loan, container.generics.params.is_empty()) {
        cx.syn_error(syn::Error::new(
            span,
            "#[ros(loan)] builds a message in place, which a borrowing form cannot be: put it on the owned form",
        ));
    }
    if let Some((name, span)) = &container.type_name {
        if let Err(why) = validate_type_name(name) {
            cx.syn_error(syn::Error::new(*span, why));
        }
    }
    let mut seen = std::collections::HashSet::new();
    for field in &container.fields {
        if let Err(why) = validate_field_name(&field.ros_name) {
            cx.syn_error(syn::Error::new(field.ros_name_span, why));
        } else if !seen.insert(field.ros_name.as_str()) {
            cx.syn_error(syn::Error::new(
                field.ros_name_span,
                format!("two fields are named `{}` in the ROS type", field.ros_name),
            ));
        }
        check_type(cx, field.ty, true);
    }
}

fn check_generics(cx: &Ctxt, container: &Container) {
    for param in &container.generics.params {
        match param {
            GenericParam::Lifetime(_) => {}
            GenericParam::Type(t) => cx.error_spanned_by(
                t,
                "RosMessage cannot be generic over types: a ROS 2 type has one layout and one type hash; use concrete field types (a lifetime for borrowed fields is fine)",
            ),
            GenericParam::Const(c) => cx.error_spanned_by(
                c,
                "RosMessage cannot be generic over constants: a ROS 2 type has one layout and one type hash; write the array length or bound as a literal",
            ),
        }
    }
}

/// `pkg/msg/Name`: lowercase package and namespace, a CamelCase name.
fn validate_type_name(name: &str) -> Result<(), String> {
    let parts: Vec<&str> = name.split('/').collect();
    let hint = "expected `package/msg/Name`, e.g. `sensor_msgs/msg/PointCloud2`";
    let [package, namespace, ty] = parts.as_slice() else {
        return Err(format!("invalid ROS 2 type name `{name}`: {hint}"));
    };
    let lower_ident = |s: &str| {
        s.chars().next().is_some_and(|c| c.is_ascii_lowercase())
            && s.chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
    };
    if !lower_ident(package) {
        return Err(format!(
            "invalid package `{package}` in `{name}`: packages are lowercase letters, digits and `_`, starting with a letter"
        ));
    }
    if !lower_ident(namespace) {
        return Err(format!(
            "invalid namespace `{namespace}` in `{name}`: {hint}"
        ));
    }
    let camel = ty.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && ty.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !camel {
        return Err(format!(
            "invalid type `{ty}` in `{name}`: type names start with an uppercase letter and hold letters, digits and `_`"
        ));
    }
    Ok(())
}

/// rosidl's field name rule: lowercase letters, digits, single underscores, starting
/// with a letter and not ending with `_`.
fn validate_field_name(name: &str) -> Result<(), String> {
    let ok = name.chars().next().is_some_and(|c| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !name.contains("__")
        && !name.ends_with('_');
    if ok {
        Ok(())
    } else {
        Err(format!(
            "`{name}` is not a valid ROS 2 field name (lowercase letters, digits and single `_`, starting with a letter, not ending with `_`): rename the field or add `#[ros(rename = \"valid_name\")]`"
        ))
    }
}

fn check_type(cx: &Ctxt, ty: &Type, top: bool) {
    match ty {
        Type::Path(path) if path.qself.is_none() => {
            let Some(last) = path.path.segments.last() else { return };
            let name = last.ident.to_string();
            let advice = match name.as_str() {
                "usize" | "isize" => Some(format!(
                    "`{name}` has no fixed size on the wire: use `{0}32` or `{0}64`",
                    &name[..1]
                )),
                "u128" | "i128" => Some("ROS 2 has no 128-bit integers: use `[u8; 16]` or two 64-bit fields".to_owned()),
                "char" => Some(
                    "a Rust `char` is a 32-bit code point, a ROS `char` is one byte: use `u8` with `#[ros(char)]`".to_owned(),
                ),
                "HashMap" | "BTreeMap" | "IndexMap" => Some(
                    "ROS 2 has no map type: use a `Vec` of a key/value struct that derives RosMessage".to_owned(),
                ),
                "HashSet" | "BTreeSet" => Some("ROS 2 has no set type: use a `Vec`".to_owned()),
                "Option" => Some(
                    "ROS 2 fields are always present: use `BoundedVec<T, 1>` for an optional value (the ROS 2 idiom)".to_owned(),
                ),
                "Box" | "Rc" | "Arc" => Some(format!("use the type inside the `{name}` directly")),
                "VecDeque" | "LinkedList" => Some("use `Vec<T>` for a sequence".to_owned()),
                _ => None,
            };
            if let Some(advice) = advice {
                cx.error_spanned_by(ty, advice);
                return;
            }
            for segment in &path.path.segments {
                if let PathArguments::AngleBracketed(args) = &segment.arguments {
                    for arg in &args.args {
                        if let GenericArgument::Type(inner) = arg {
                            check_type(cx, inner, false);
                        }
                    }
                }
            }
        }
        Type::Reference(reference) => {
            let borrowable = match &*reference.elem {
                Type::Path(p) => p.path.is_ident("str"),
                Type::Slice(s) => matches!(&*s.elem, Type::Path(p) if p.path.is_ident("u8")),
                _ => false,
            };
            if reference.mutability.is_some() || !borrowable {
                cx.error_spanned_by(
                    ty,
                    "borrowed fields can only be `&'a str` or `&'a [u8]`: use an owned type such as `String` or `Vec<T>`, or `Cow<'a, [T]>`",
                );
            }
        }
        Type::Array(array) => check_type(cx, &array.elem, false),
        Type::Paren(inner) => check_type(cx, &inner.elem, top),
        Type::Group(inner) => check_type(cx, &inner.elem, top),
        Type::Tuple(tuple) => cx.error_spanned_by(
            tuple,
            if tuple.elems.is_empty() {
                "`()` carries no data: remove the field"
            } else {
                "ROS 2 has no tuples: use a nested struct that derives RosMessage"
            },
        ),
        Type::Slice(_) if top => cx.error_spanned_by(ty, "an unsized slice cannot be a field: use `Vec<T>`, `&'a [u8]` or `[T; N]`"),
        // `Cow<'a, [T]>`: check the element.
        Type::Slice(slice) => check_type(cx, &slice.elem, false),
        Type::Ptr(_) | Type::BareFn(_) | Type::TraitObject(_) | Type::ImplTrait(_) | Type::Never(_) => {
            cx.error_spanned_by(ty, "not a ROS 2 field type: use numbers, bool, strings, sequences, arrays or a struct that derives RosMessage")
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names() {
        assert!(validate_type_name("sensor_msgs/msg/PointCloud2").is_ok());
        assert!(validate_type_name("example_interfaces/srv/AddTwoInts_Request").is_ok());
        assert!(validate_type_name("PointCloud2").is_err());
        assert!(validate_type_name("Sensor/msg/X").is_err());
        assert!(validate_type_name("a/msg/lower").is_err());
        assert!(validate_type_name("a/b/c/D").is_err());
    }

    #[test]
    fn field_names() {
        assert!(validate_field_name("frame_id").is_ok());
        assert!(validate_field_name("x2").is_ok());
        assert!(validate_field_name("frameId").is_err());
        assert!(validate_field_name("a__b").is_err());
        assert!(validate_field_name("a_").is_err());
        assert!(validate_field_name("_a").is_err());
    }
}
