//! The derive input read into an intermediate form: the struct, its resolved ROS
//! type name and its fields with their attributes.

use syn::{Data, DeriveInput, Fields, Ident, Type};

use crate::attr::{ContainerAttrs, FieldAttrs};
use crate::ctxt::Ctxt;

pub struct Container<'a> {
    pub ident: &'a Ident,
    pub vis: &'a syn::Visibility,
    pub generics: &'a syn::Generics,
    pub attrs: ContainerAttrs,
    /// `pkg/msg/Name`, from `type_name` or `package` (validated in `check`).
    pub type_name: Option<(String, proc_macro2::Span)>,
    pub fields: Vec<Field<'a>>,
}

pub struct Field<'a> {
    pub member: &'a Ident,
    /// The field name in the type description: `rename`, or the Rust name without `r#`.
    pub ros_name: String,
    pub ros_name_span: proc_macro2::Span,
    pub ty: &'a Type,
    pub vis: &'a syn::Visibility,
    pub attrs: FieldAttrs,
}

impl<'a> Container<'a> {
    pub fn from_ast(cx: &Ctxt, input: &'a DeriveInput) -> Option<Self> {
        let attrs = ContainerAttrs::from_ast(cx, &input.attrs);
        let fields = match &input.data {
            Data::Struct(data) => match &data.fields {
                Fields::Named(named) => named
                    .named
                    .iter()
                    .filter_map(|f| Field::from_ast(cx, f))
                    .collect(),
                Fields::Unit => Vec::new(),
                Fields::Unnamed(unnamed) => {
                    cx.error_spanned_by(
                        unnamed,
                        "RosMessage needs named fields (ROS fields have names): write `struct Name { field: Type }`",
                    );
                    return None;
                }
            },
            Data::Enum(data) => {
                cx.error_spanned_by(
                    data.enum_token,
                    "RosMessage cannot be derived for an enum: ROS 2 messages are structs; use an integer field (e.g. `u8`) with associated constants",
                );
                return None;
            }
            Data::Union(data) => {
                cx.error_spanned_by(
                    data.union_token,
                    "RosMessage cannot be derived for a union: ROS 2 messages are structs with named fields",
                );
                return None;
            }
        };
        let type_name = match (&attrs.type_name, &attrs.package) {
            (Some(name), None) => Some((name.value(), name.span())),
            (None, Some(package)) => Some((
                format!("{}/msg/{}", package.value(), input.ident),
                package.span(),
            )),
            (Some(name), Some(_)) => {
                cx.error_spanned_by(
                    name,
                    "give either `type_name = \"pkg/msg/Name\"` or `package = \"pkg\"`, not both",
                );
                None
            }
            (None, None) if attrs.malformed => None,
            (None, None) => {
                cx.error_spanned_by(
                    &input.ident,
                    format!(
                        "a ROS 2 type name needs a package: add `#[ros(type_name = \"my_pkg/msg/{0}\")]` or `#[ros(package = \"my_pkg\")]`",
                        input.ident
                    ),
                );
                None
            }
        };
        Some(Self {
            ident: &input.ident,
            vis: &input.vis,
            generics: &input.generics,
            attrs,
            type_name,
            fields,
        })
    }
}

impl<'a> Field<'a> {
    fn from_ast(cx: &Ctxt, field: &'a syn::Field) -> Option<Self> {
        let member = field.ident.as_ref()?;
        let attrs = FieldAttrs::from_ast(cx, &field.attrs);
        let (ros_name, ros_name_span) = match &attrs.rename {
            Some(rename) => (rename.value(), rename.span()),
            None => {
                let name = member.to_string();
                (
                    name.strip_prefix("r#").unwrap_or(&name).to_owned(),
                    member.span(),
                )
            }
        };
        Some(Self {
            member,
            ros_name,
            ros_name_span,
            ty: &field.ty,
            vis: &field.vis,
            attrs,
        })
    }
}
