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
/// | `String`, `&'a str`, `Cow<'a, str>`, `compact_str::CompactString` (shm-cdr's feature `compact_str`: up to 24 bytes inline, no allocation to decode) | `string` |
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
/// ```
/// use std::borrow::Cow;
///
/// use shm_cdr::{BoundedString, RosMessage};
///
/// /// robot_msgs/msg/Cell
/// #[derive(RosMessage, Debug, PartialEq, Clone, Default)]
/// #[ros(package = "robot_msgs")]
/// struct Cell {
///     voltage: f32,        // float32 voltage
///     temperature: f32,    // float32 temperature
/// }
///
/// /// robot_msgs/msg/BatteryState, as its .msg file would say.
/// #[derive(RosMessage, Debug, PartialEq)]
/// #[ros(package = "robot_msgs")] // the type name is robot_msgs/msg/BatteryState
/// struct BatteryState<'a> {
///     voltage: f32,              // float32 voltage
///     cells: Vec<Cell>,          // Cell[] cells
///     #[ros(byte)]
///     status: u8,                // byte status
///     serial: BoundedString<32>, // string<=32 serial
///     #[ros(rename = "location")]
///     place: Cow<'a, str>,       // string location
/// }
///
/// assert_eq!(BatteryState::TYPE_NAME, "robot_msgs/msg/BatteryState");
/// let msg = BatteryState {
///     voltage: 24.1,
///     cells: vec![Cell::default(); 6],
///     status: 1,
///     serial: "B-0042".into(),
///     place: "dock".into(),
/// };
/// let bytes = shm_cdr::to_vec(&msg)?;
/// assert_eq!(bytes.len(), shm_cdr::encoded_size(&msg));
/// assert_eq!(shm_cdr::from_bytes::<BatteryState>(&bytes)?, msg);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// See `shm_cdr`'s crate documentation for more.
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
        // The errors, and impls that never run, so that the type's uses do
        // not each add an error of their own: one error per mistake.
        (Err(errors), container) => {
            let krate = container.as_ref().and_then(|c| c.attrs.crate_path.as_ref());
            let mut out = errors.to_compile_error();
            out.extend(expand::placeholder(&input, krate));
            out.into()
        }
        (Ok(()), None) => TokenStream::new(),
    }
}
