//! `#[derive(RosMessage)]` for [shm-cdr](https://docs.rs/shm-cdr): generates the
//! CDR writer, reader, exact size function and ROS 2 type description of a struct.
//!
//! Use it through `shm_cdr::RosMessage`; see that crate for the attributes.
//!
//! The macro reads the input into an IR (`ast`, `attr`) collecting every error
//! with its span, validates it (`check`), then generates code (`expand`).

mod ast;
mod attr;
mod check;
mod ctxt;
mod expand;
mod loan;

use proc_macro::TokenStream;
use syn::{parse_macro_input, DeriveInput};

/// Derive `CdrEncode`, `CdrDecode`, `RosType` and `RosMessage` for a struct with
/// named fields.
///
/// Struct attributes: `#[ros(type_name = "pkg/msg/Name")]` or
/// `#[ros(package = "pkg")]` (required, one of them), `#[ros(crate = "path")]`,
/// `#[ros(loan)]`.
///
/// With `#[ros(loan)]`, on a struct `Name` with no generic parameters, it also
/// generates `NameLens` and `NameMut<'a>` and implements
/// `shm_cdr::loan::InPlace`, to build the message in place in its final buffer
/// (see `shm_cdr::loan`). Its nested message types need `#[ros(loan)]` too; every
/// generated standard interface has it.
/// Field attributes: `#[ros(byte)]`, `#[ros(char)]` (on `u8`/`i8` fields and their
/// sequences/arrays), `#[ros(rename = "ros_name")]`.
///
/// Field types (anything else is a compile error that says what to write
/// instead):
///
/// | Rust | ROS 2 |
/// |---|---|
/// | `bool`, `u8`…`u64`, `i8`…`i64`, `f32`, `f64` | the same primitives (`#[ros(byte)]` / `#[ros(char)]` on `u8`/`i8` for `byte` / `char`) |
/// | `String`, `&'a str`, `Cow<'a, str>` | `string` |
/// | `BoundedString<N>` | `string<=N` |
/// | `WString`, `BoundedWString<N>` | `wstring`, `wstring<=N` |
/// | `Vec<T>`, `&'a [u8]`, `Cow<'a, [T]>`, `bytes::Bytes` | `T[]` (`&[u8]` and `Cow<[u8]>` borrow) |
/// | `BoundedVec<T, N>` | `T[<=N]` |
/// | `[T; N]` | `T[N]` |
/// | a struct deriving `RosMessage` (or a `…Ref<'a>` form, or `<T as BorrowedForm>::Ref<'a>`) | a nested message |
///
/// Refused, with the fix in the message: `usize`/`isize`, `u128`/`i128`, Rust
/// `char`, maps and sets, `Option`, `Box`/`Rc`/`Arc`, tuples, enums, tuple
/// structs, type generics, `Vec<Vec<T>>`, and `#[ros(byte)]` on a non-byte field.
///
/// See `shm_cdr`'s crate documentation for a worked example.
#[proc_macro_derive(RosMessage, attributes(ros))]
pub fn derive_ros_message(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    let cx = ctxt::Ctxt::default();
    let container = ast::Container::from_ast(&cx, &input);
    if let Some(container) = &container {
        check::check(&cx, container);
    }
    match (cx.check(), container) {
        (Ok(()), Some(container)) => expand::expand(&container).into(),
        (Err(errors), _) => errors.to_compile_error().into(),
        (Ok(()), None) => TokenStream::new(),
    }
}
