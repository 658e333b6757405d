//! What a program that defines, encodes or loans messages needs in scope:
//! `use shm_cdr::prelude::*;`.
//!
//! ```
//! use shm_cdr::prelude::*;
//!
//! #[derive(RosMessage, Debug, PartialEq)]
//! #[ros(type_name = "my_pkg/msg/Reading", loan)]
//! struct Reading {
//!     label: String,
//!     values: Vec<f64>,
//! }
//!
//! let reading = Reading { label: "t".into(), values: vec![1.5] };
//! let lens = reading.lens(); // InPlace: the lengths to loan one like it
//! assert_eq!(lens.values, 1);
//! let bytes = shm_cdr::to_vec(&reading)?;
//! assert_eq!(shm_cdr::from_bytes::<Reading>(&bytes)?, reading);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use crate::loan::{InPlace, SeqLens};
pub use crate::{
    BorrowedForm, BoundedString, BoundedVec, BoundedWString, RosAction, RosMessage, RosService,
    WString,
};
