//! Code generation from the validated IR: `CdrEncode`, `CdrDecode`, `RosType`,
//! `RosElement` and `RosMessage`.

use proc_macro2::TokenStream;
use quote::{quote, quote_spanned};
use syn::spanned::Spanned;
use syn::{GenericParam, Lifetime, LifetimeParam, LitStr};

use crate::ast::Container;
use crate::attr::OctetKind;

pub fn expand(container: &Container) -> TokenStream {
    let krate = match &container.attrs.crate_path {
        Some(path) => quote!(#path),
        None => quote!(::shm_cdr),
    };
    let ident = container.ident;
    let rust_name = ident.to_string();
    let type_name = container
        .type_name
        .as_ref()
        .map(|(name, _)| name.clone())
        .unwrap_or_default();
    let dds_name = dds_type_name(&type_name);
    let (impl_generics, ty_generics, where_clause) = container.generics.split_for_impl();

    let members: Vec<_> = container.fields.iter().map(|f| f.member).collect();
    let types: Vec<_> = container.fields.iter().map(|f| f.ty).collect();
    let ros_names: Vec<_> = container
        .fields
        .iter()
        .map(|f| f.ros_name.as_str())
        .collect();
    let empty = container.fields.is_empty();

    // --- size -------------------------------------------------------------------
    let size_body = if empty {
        quote!(start + 1)
    } else {
        quote! {
            let pos = start;
            #( let pos = #krate::CdrEncode::encoded_end(&self.#members, pos); )*
            pos
        }
    };

    // --- encode -----------------------------------------------------------------
    let encode_body = if empty {
        // rosidl's `structure_needs_at_least_one_member`.
        quote!(#krate::CdrEncode::encode(&0u8, __w))
    } else {
        quote! {
            #(
                #krate::CdrEncode::encode(&self.#members, __w)
                    .map_err(|e| e.in_field(#rust_name, #ros_names))?;
            )*
            ::core::result::Result::Ok(())
        }
    };

    // --- splicing (`shm_cdr::splice`) --------------------------------------------
    let splice_bodies = if empty {
        None
    } else {
        Some((
            quote! {
                let pos = start;
                #( let pos = #krate::CdrEncode::spliced_end(&self.#members, pos, __sizing); )*
                pos
            },
            quote! {
                #(
                    #krate::CdrEncode::encode_spliced(&self.#members, __w, __sink)
                        .map_err(|e| e.in_field(#rust_name, #ros_names))?;
                )*
                ::core::result::Result::Ok(())
            },
        ))
    };
    let splice_methods = splice_bodies.map(|(size, write)| {
        quote! {
            const SPLICES: bool = false #( || <#types as #krate::CdrEncode>::SPLICES )*;

            #[inline]
            fn spliced_end(
                &self,
                start: usize,
                __sizing: &mut #krate::splice::SpliceSizing,
            ) -> usize {
                if !<Self as #krate::CdrEncode>::SPLICES {
                    return #krate::CdrEncode::encoded_end(self, start);
                }
                #size
            }

            #[inline]
            fn encode_spliced<__B: #krate::ByteOrder>(
                &self,
                __w: &mut #krate::Writer<'_, __B>,
                __sink: &mut dyn #krate::splice::SpliceSink,
            ) -> ::core::result::Result<(), #krate::EncodeError> {
                if !<Self as #krate::CdrEncode>::SPLICES {
                    return #krate::CdrEncode::encode(self, __w);
                }
                #write
            }
        }
    });

    // --- bulk-copy proof ----------------------------------------------------------
    let plain = |trait_path: TokenStream| {
        if empty {
            return quote!(::core::option::Option::None);
        }
        quote! {
            // SAFETY: the list holds every field of `Self` in declaration order, with
            // its `offset_of!` and `size_of` taken from `Self` itself and the proof of
            // the field's own type, as `of_struct` requires.
            unsafe {
                #krate::layout::PlainLayout::of_struct(
                    &[ #(
                        #krate::layout::PlainField {
                            offset: ::core::mem::offset_of!(Self, #members),
                            size: ::core::mem::size_of::<#types>(),
                            plain: #krate::layout::PlainLayout::erase(<#types as #trait_path>::PLAIN),
                        }
                    ),* ],
                    ::core::mem::size_of::<Self>(),
                )
            }
        }
    };

    // --- decode -----------------------------------------------------------------
    let de = Lifetime::new("'__de", proc_macro2::Span::call_site());
    let mut de_generics = container.generics.clone();
    let bounds: Vec<Lifetime> = container
        .generics
        .lifetimes()
        .map(|l| l.lifetime.clone())
        .collect();
    let mut de_param = LifetimeParam::new(de.clone());
    de_param.bounds.extend(bounds);
    de_generics
        .params
        .insert(0, GenericParam::Lifetime(de_param));
    let (de_impl_generics, _, _) = de_generics.split_for_impl();

    let plain_encode = plain(quote!(#krate::CdrEncode));
    let plain_decode = plain(quote!(#krate::CdrDecode<#de>));
    let min_wire_size = if empty {
        quote!(1)
    } else {
        quote!(0 #( + <#types as #krate::CdrDecode<#de>>::MIN_WIRE_SIZE )*)
    };
    // Field by field into the existing value, so each field keeps what it owns.
    // An empty message has nothing to reuse: the default (`decode`) serves.
    let decode_into = (!empty).then(|| {
        quote! {
            #[inline]
            fn decode_into<__B: #krate::ByteOrder>(
                &mut self,
                __r: &mut #krate::Reader<#de, __B>,
            ) -> ::core::result::Result<(), #krate::DecodeError> {
                #(
                    #krate::CdrDecode::decode_into(&mut self.#members, __r)
                        .map_err(|e| e.in_field(#rust_name, #ros_names))?;
                )*
                ::core::result::Result::Ok(())
            }
        }
    });
    let decode_body = if empty {
        quote! {
            let _: u8 = #krate::CdrDecode::decode(__r)?;
            ::core::result::Result::Ok(Self {})
        }
    } else {
        quote! {
            ::core::result::Result::Ok(Self {
                #(
                    #members: #krate::CdrDecode::decode(__r)
                        .map_err(|e| e.in_field(#rust_name, #ros_names))?,
                )*
            })
        }
    };

    // --- description ------------------------------------------------------------
    let field_descriptions: Vec<TokenStream> = if empty {
        vec![quote! {
            #krate::describe::Field::new(
                #krate::describe::PLACEHOLDER_MEMBER,
                #krate::describe::FieldType::scalar(#krate::describe::TypeId::Uint8),
            )
        }]
    } else {
        container
            .fields
            .iter()
            .map(|f| {
                let ty = f.ty;
                let name = &f.ros_name;
                let adjust = match f.attrs.octet {
                    Some((OctetKind::Byte, _)) => quote!(.as_byte()),
                    Some((OctetKind::Char, _)) => quote!(.as_char()),
                    None => quote!(),
                };
                let default_value = f
                    .attrs
                    .default_value
                    .as_ref()
                    .map(|value| quote!(.with_default_value(#value)));
                quote! {
                    #krate::describe::Field::new(
                        #name,
                        <#ty as #krate::RosType>::FIELD_TYPE #adjust,
                    ) #default_value
                }
            })
            .collect()
    };

    // Assertions spanned at each field's type, so a wrong type is reported there.
    let field_checks = container.fields.iter().map(|f| {
        let ty = f.ty;
        let octet = f
            .attrs
            .octet
            .map(|(_, span)| quote_spanned!(span=> #krate::__private::assert_octet_type::<#ty>();));
        let span = ty.span();
        quote_spanned! {span=>
            #krate::__private::assert_field_type::<#ty>();
            #octet
        }
    });

    let in_place = crate::loan::expand(container, &krate);

    let attrs = &container.attrs;
    let source = match (&attrs.source_encoding, &attrs.source) {
        (None, None) => quote!(),
        (Some(encoding), None) if encoding.value() == "implicit" => quote! {
            const SOURCE: #krate::describe::TypeSource = #krate::describe::TypeSource::IMPLICIT;
        },
        (encoding, text) => {
            let encoding = encoding
                .as_ref()
                .map_or_else(|| "msg".to_owned(), LitStr::value);
            let text = text
                .as_ref()
                .map_or_else(|| quote!(""), |text| quote!(#text));
            quote! {
                const SOURCE: #krate::describe::TypeSource =
                    #krate::describe::TypeSource::file(#encoding, #text);
            }
        }
    };

    quote! {
        #in_place

        #[automatically_derived]
        #[allow(clippy::all, clippy::pedantic)]
        const _: () = {
            fn __field_checks #impl_generics () #where_clause {
                #(#field_checks)*
            }

            impl #impl_generics #krate::CdrEncode for #ident #ty_generics #where_clause {
                const FIXED_LAYOUT: ::core::option::Option<#krate::layout::FixedLayout> =
                    #krate::layout::FixedLayout::of_struct(&[
                        #( <#types as #krate::CdrEncode>::FIXED_LAYOUT, )*
                    ]);

                const PLAIN: ::core::option::Option<#krate::layout::PlainLayout<Self>> = #plain_encode;

                #[inline]
                fn encoded_end(&self, start: usize) -> usize {
                    if let ::core::option::Option::Some(layout) = Self::FIXED_LAYOUT {
                        return layout.end(start);
                    }
                    #size_body
                }

                #[inline]
                fn encode<__B: #krate::ByteOrder>(
                    &self,
                    __w: &mut #krate::Writer<'_, __B>,
                ) -> ::core::result::Result<(), #krate::EncodeError> {
                    #encode_body
                }

                #splice_methods
            }

            impl #de_impl_generics #krate::CdrDecode<#de> for #ident #ty_generics #where_clause {
                const MIN_WIRE_SIZE: usize = #min_wire_size;

                const PLAIN: ::core::option::Option<#krate::layout::PlainLayout<Self>> = #plain_decode;

                #[inline]
                fn decode<__B: #krate::ByteOrder>(
                    __r: &mut #krate::Reader<#de, __B>,
                ) -> ::core::result::Result<Self, #krate::DecodeError> {
                    #decode_body
                }

                #decode_into
            }

            impl #impl_generics #krate::RosType for #ident #ty_generics #where_clause {
                const FIELD_TYPE: #krate::describe::FieldType =
                    #krate::describe::FieldType::nested(#type_name);

                fn register_types(registry: &mut #krate::describe::TypeRegistry) {
                    if registry.insert(<Self as #krate::RosMessage>::type_description()) {
                        #( <#types as #krate::RosType>::register_types(registry); )*
                    }
                }
            }

            impl #impl_generics #krate::RosElement for #ident #ty_generics #where_clause {}

            impl #impl_generics #krate::RosMessage for #ident #ty_generics #where_clause {
                const TYPE_NAME: &'static str = #type_name;
                const DDS_TYPE_NAME: &'static str = #dds_name;
                const FIELDS: &'static [#krate::describe::Field] = &[ #(#field_descriptions),* ];
                #source

                fn type_hash() -> &'static str {
                    static HASH: #krate::__private::OnceLock<::std::string::String> =
                        #krate::__private::OnceLock::new();
                    HASH.get_or_init(#krate::describe::compute_type_hash::<Self>)
                }
            }
        };
    }
}

/// For a type the derive refused: the traits it would implement, with bodies
/// that never run (the crate does not compile, the derive's errors say why).
/// Without them every use of the type adds an error that the trait is not
/// implemented, listing every type that implements it.
pub fn placeholder(input: &syn::DeriveInput, crate_path: Option<&syn::Path>) -> TokenStream {
    let krate = match crate_path {
        Some(path) => quote!(#path),
        None => quote!(::shm_cdr),
    };
    let ident = &input.ident;
    let (impl_generics, ty_generics, where_clause) = input.generics.split_for_impl();
    let de = Lifetime::new("'__de", proc_macro2::Span::call_site());
    let mut de_generics = input.generics.clone();
    let mut de_param = LifetimeParam::new(de.clone());
    de_param
        .bounds
        .extend(input.generics.lifetimes().map(|l| l.lifetime.clone()));
    de_generics
        .params
        .insert(0, GenericParam::Lifetime(de_param));
    let (de_impl_generics, _, _) = de_generics.split_for_impl();
    quote! {
        #[automatically_derived]
        #[allow(clippy::all, clippy::pedantic, unused)]
        const _: () = {
            impl #impl_generics #krate::CdrEncode for #ident #ty_generics #where_clause {
                fn encoded_end(&self, _: usize) -> usize {
                    ::core::unreachable!()
                }
                fn encode<__B: #krate::ByteOrder>(
                    &self,
                    _: &mut #krate::Writer<'_, __B>,
                ) -> ::core::result::Result<(), #krate::EncodeError> {
                    ::core::unreachable!()
                }
            }
            impl #de_impl_generics #krate::CdrDecode<#de> for #ident #ty_generics #where_clause {
                const MIN_WIRE_SIZE: usize = 0;
                fn decode<__B: #krate::ByteOrder>(
                    _: &mut #krate::Reader<#de, __B>,
                ) -> ::core::result::Result<Self, #krate::DecodeError> {
                    ::core::unreachable!()
                }
            }
            impl #impl_generics #krate::RosType for #ident #ty_generics #where_clause {
                const FIELD_TYPE: #krate::describe::FieldType =
                    #krate::describe::FieldType::nested("");
            }
            impl #impl_generics #krate::RosElement for #ident #ty_generics #where_clause {}
            impl #impl_generics #krate::RosMessage for #ident #ty_generics #where_clause {
                const TYPE_NAME: &'static str = "";
                const DDS_TYPE_NAME: &'static str = "";
                const FIELDS: &'static [#krate::describe::Field] = &[];
                fn type_hash() -> &'static str {
                    ::core::unreachable!()
                }
            }
        };
    }
}

/// `pkg/msg/Name` → `pkg::msg::dds_::Name_`.
fn dds_type_name(type_name: &str) -> String {
    match type_name.rsplit_once('/') {
        Some((namespace, name)) => format!("{}::dds_::{name}_", namespace.replace('/', "::")),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn dds_names() {
        assert_eq!(
            super::dds_type_name("sensor_msgs/msg/PointCloud2"),
            "sensor_msgs::msg::dds_::PointCloud2_"
        );
    }
}
