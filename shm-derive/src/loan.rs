//! Code generation for building messages in place: the `…Lens` and `…Mut` types
//! and the `InPlace` / `InPlaceElement` implementations.

use proc_macro2::{Span, TokenStream};
use quote::{format_ident, quote};

use crate::ast::Container;

/// The in-place types and impls for a container marked `#[ros(loan)]` (`check`
/// refuses the attribute on a generic struct: borrowing forms are read, not built).
///
/// Opt-in, because a field type without `InPlace` makes every use of its `Lens`
/// and `Mut` an error: a struct that is not a message would bury its one clear
/// error under a dozen.
pub fn expand(container: &Container, krate: &TokenStream) -> TokenStream {
    if container.attrs.loan.is_none() || !container.generics.params.is_empty() {
        return TokenStream::new();
    }
    let ident = container.ident;
    let vis = container.vis;
    let lens_ident = format_ident!("{}Lens", ident);
    let mut_ident = format_ident!("{}Mut", ident);
    let members: Vec<_> = container.fields.iter().map(|f| f.member).collect();
    // The Rust names, for errors that name the field a wrong length went to.
    let member_names: Vec<_> = container
        .fields
        .iter()
        .map(|f| syn::ext::IdentExt::unraw(f.member).to_string())
        .collect();
    let types: Vec<_> = container.fields.iter().map(|f| f.ty).collect();
    let field_vis: Vec<_> = container.fields.iter().map(|f| f.vis).collect();
    let lens_docs = container
        .fields
        .iter()
        .map(|f| format!("The lengths of `{}` (`()` if it has none).", f.member));
    let mut_docs = container
        .fields
        .iter()
        .map(|f| format!("Where `{}` goes in the buffer.", f.member));
    let name = ident.to_string();
    let lens_doc = format!(
        "The lengths of the strings and sequences of a [`{name}`], from which it is laid out in place (`{name}::lens` of a value gives them; see [`loan`]({}::loan)).",
        quote!(#krate).to_string().replace(' ', "")
    );
    let mut_doc = format!(
        "A [`{name}`] laid out in a buffer: every field at its final offset, to be written in place (numbers as `&mut`, strings and sequences as slots)."
    );
    let a = syn::Lifetime::new("'__a", Span::call_site());
    let in_place = quote!(#krate::loan::InPlace);

    let empty = container.fields.is_empty();
    let marker_field = empty.then(|| {
        quote! {
            #[doc(hidden)]
            pub __buffer: ::core::marker::PhantomData<&#a mut [u8]>,
        }
    });
    let (end_body, carve_body, write_body) = if empty {
        // An empty message is one zero byte (rosidl's placeholder member).
        (
            quote!(start.checked_add(1)),
            quote! {
                __c.take(1, 1)?.fill(0);
                ::core::result::Result::Ok(#mut_ident { __buffer: ::core::marker::PhantomData })
            },
            quote!(::core::result::Result::Ok(())),
        )
    } else {
        (
            quote! {
                let pos = start;
                #( let pos = <#types as #in_place>::end_in_place(&lens.#members, pos)?; )*
                ::core::option::Option::Some(pos)
            },
            quote! {
                ::core::result::Result::Ok(#mut_ident {
                    #( #members: {
                        __c.field(#member_names);
                        <#types as #in_place>::carve(&lens.#members, __c)?
                    }, )*
                })
            },
            quote! {
                let #mut_ident { #(#members),* } = place;
                #( #in_place::write_in_place(&self.#members, #members)?; )*
                ::core::result::Result::Ok(())
            },
        )
    };

    quote! {
        #[doc = #lens_doc]
        #[derive(Debug, Clone, Default, PartialEq)]
        #[allow(clippy::all, clippy::pedantic)]
        #vis struct #lens_ident {
            #( #[doc = #lens_docs] #field_vis #members: <#types as #in_place>::Lens, )*
        }

        #[doc = #mut_doc]
        #[allow(clippy::all, clippy::pedantic)]
        #vis struct #mut_ident<#a> {
            #( #[doc = #mut_docs] #field_vis #members: <#types as #in_place>::Mut<#a>, )*
            #marker_field
        }

        #[automatically_derived]
        #[allow(clippy::all, clippy::pedantic)]
        const _: () = {
            impl #in_place for #ident {
                type Lens = #lens_ident;
                type Mut<#a> = #mut_ident<#a>;

                #[inline]
                fn lens(&self) -> #lens_ident {
                    #lens_ident { #( #members: #in_place::lens(&self.#members), )* }
                }

                #[inline]
                fn end_in_place(lens: &#lens_ident, start: usize) -> ::core::option::Option<usize> {
                    let _ = lens;
                    #end_body
                }

                #[inline]
                fn carve<#a>(
                    lens: &#lens_ident,
                    __c: &mut #krate::loan::Carver<#a>,
                ) -> ::core::result::Result<#mut_ident<#a>, #krate::loan::LoanError> {
                    let _ = lens;
                    #carve_body
                }

                #[inline]
                fn write_in_place(
                    &self,
                    place: #mut_ident<'_>,
                ) -> ::core::result::Result<(), #krate::loan::LoanError> {
                    #write_body
                }
            }

            impl #krate::loan::InPlaceElement for #ident {
                type RunLens = #krate::loan::SeqLens<#lens_ident>;
                type RunMut<#a> = #krate::loan::Run<#a, Self>;
                type ArrayLens = #krate::loan::SeqLens<#lens_ident>;
                type ArrayMut<#a, const __N: usize> = #krate::loan::Run<#a, Self>;

                #[inline]
                fn run_lens(items: &[Self]) -> Self::RunLens {
                    #krate::loan::struct_run_lens(items)
                }

                #[inline]
                fn run_count(lens: &Self::RunLens) -> usize {
                    #krate::loan::struct_run_count(lens)
                }

                #[inline]
                fn run_end(lens: &Self::RunLens, n: usize, start: usize) -> ::core::option::Option<usize> {
                    #krate::loan::struct_run_end::<Self>(lens, n, start)
                }

                #[inline]
                fn carve_run<#a>(
                    lens: &Self::RunLens,
                    n: usize,
                    c: &mut #krate::loan::Carver<#a>,
                ) -> ::core::result::Result<Self::RunMut<#a>, #krate::loan::LoanError> {
                    #krate::loan::struct_carve_run(lens, n, c)
                }

                #[inline]
                fn write_run(
                    items: &[Self],
                    place: Self::RunMut<'_>,
                ) -> ::core::result::Result<(), #krate::loan::LoanError> {
                    #krate::loan::struct_write_run(items, place)
                }

                #[inline]
                fn array_lens<const __N: usize>(items: &[Self; __N]) -> Self::ArrayLens {
                    #krate::loan::struct_run_lens(items)
                }

                #[inline]
                fn array_end<const __N: usize>(lens: &Self::ArrayLens, start: usize) -> ::core::option::Option<usize> {
                    #krate::loan::struct_array_end::<Self>(lens, __N, start)
                }

                #[inline]
                fn carve_array<#a, const __N: usize>(
                    lens: &Self::ArrayLens,
                    c: &mut #krate::loan::Carver<#a>,
                ) -> ::core::result::Result<Self::ArrayMut<#a, __N>, #krate::loan::LoanError> {
                    #krate::loan::struct_carve_array(lens, __N, c)
                }

                #[inline]
                fn write_array<const __N: usize>(
                    items: &[Self; __N],
                    place: Self::ArrayMut<'_, __N>,
                ) -> ::core::result::Result<(), #krate::loan::LoanError> {
                    #krate::loan::struct_write_run(items, place)
                }
            }
        };
    }
}
