//! Property tests over many message shapes: `encoded_size == to_vec().len()`,
//! `encode_into` an exact garbage-filled buffer equals `to_vec`, one byte short
//! fails cleanly, and decode(encode(x)) == x, in both byte orders
//! (`shm_cdr::testing::check_roundtrip`), and decoding into a value that held
//! another message gives exactly the new one (`check_decode_into`). Shapes are
//! shifted to odd start phases by
//! wrapper structs so that alignment is exercised at every offset.

use proptest::prelude::*;
use proptest_derive::Arbitrary;
use shm_cdr::testing::{check_decode_into, check_in_place, check_roundtrip};
use shm_cdr::{BoundedString, BoundedVec, BoundedWString, RosMessage, WString};
use shm_cdr_tests::msgs::{HeaderRef, Image, ImageRef, Time};

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Scalars", loan)]
struct Scalars {
    b: bool,
    u8: u8,
    i8: i8,
    u16: u16,
    i16: i16,
    u32: u32,
    i32: i32,
    u64: u64,
    i64: i64,
    f32: f32,
    f64: f64,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Texts", loan)]
struct Texts {
    s: String,
    many: Vec<String>,
    bounded: BoundedString<5>,
    bounded_many: BoundedVec<BoundedString<3>, 4>,
    wide: WString,
    wide_bounded: BoundedWString<4>,
    wide_many: Vec<WString>,
    trio: [String; 3],
}

#[derive(RosMessage, Arbitrary, Debug, Clone, Copy, PartialEq)]
#[ros(type_name = "prop/msg/Stamp", loan)]
struct Stamp {
    sec: i32,
    nanosec: u32,
}

/// CDR pads between `stamp` and `value` only when the element starts 8-aligned + 4.
#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Stamped", loan)]
struct Stamped {
    stamp: Stamp,
    value: f64,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/PairU32", loan)]
struct PairU32 {
    a: u32,
    b: u32,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/OddTail", loan)]
struct OddTail {
    x: f64,
    tag: u8,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Nested", loan)]
struct Nested {
    lead: u8,
    stamped: Vec<Stamped>,
    pairs: Vec<PairU32>,
    odd: Vec<OddTail>,
    mid: u16,
    pair_in_struct: PairU32,
    fixed: [Stamped; 2],
    label: String,
    tail: u8,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Arrays", loan)]
struct Arrays {
    lead: u8,
    f: [f64; 3],
    b: [bool; 4],
    i: [i16; 5],
    u: [u8; 7],
    odd: [OddTail; 3],
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Seqs", loan)]
struct Seqs {
    lead: u8,
    v8: Vec<u8>,
    v16: Vec<i16>,
    v32: Vec<f32>,
    v64: Vec<u64>,
    vb: Vec<bool>,
    vf: Vec<f64>,
    vi8: Vec<i8>,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Bounded", loan)]
struct Bounded {
    ints: BoundedVec<i32, 3>,
    stamped: BoundedVec<Stamped, 2>,
    octets: BoundedVec<u8, 16>,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Nothing", loan)]
struct Nothing;

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/WithEmpty", loan)]
struct WithEmpty {
    a: u8,
    e: Nothing,
    many: Vec<Nothing>,
    f: f64,
}

#[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
#[ros(type_name = "prop/msg/Octets", loan)]
struct Octets {
    #[ros(byte)]
    b: u8,
    #[ros(char)]
    c: i8,
    #[ros(byte)]
    blob: Vec<u8>,
}

macro_rules! shifted {
    ($($name:ident($lead:ty, $inner:ty)),* $(,)?) => {$(
        /// `$inner` starting after a `$lead`, i.e. at another alignment phase.
        #[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
        #[ros(package = "prop", loan)]
        struct $name {
            lead: $lead,
            inner: $inner,
        }
    )*};
}

shifted! {
    NestedAt1(u8, Nested),
    NestedAt2(u16, Nested),
    NestedAt4(u32, Nested),
    ArraysAt1(u8, Arrays),
    ArraysAt4(u32, Arrays),
    SeqsAt1(u8, Seqs),
    ScalarsAt1(u8, Scalars),
    ScalarsAt2(u16, Scalars),
    TextsAt1(u8, Texts),
    BoundedAt1(u8, Bounded),
    WithEmptyAt4(u32, WithEmpty),
}

macro_rules! roundtrip_properties {
    ($($test:ident: $ty:ty),* $(,)?) => {
        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]
            $(
                #[test]
                fn $test(msg in any::<$ty>()) {
                    if let Err(why) = check_roundtrip(&msg) {
                        prop_assert!(false, "{}", why);
                    }
                    // Built in place, field by field, into a garbage-filled buffer.
                    if let Err(why) = check_in_place(&msg) {
                        prop_assert!(false, "in place: {}", why);
                    }
                }
            )*
        }

        /// Decoding over an earlier, different message leaves nothing of it.
        mod decode_into {
            use super::*;

            proptest! {
                #![proptest_config(ProptestConfig::with_cases(128))]
                $(
                    #[test]
                    fn $test(previous in any::<$ty>(), msg in any::<$ty>()) {
                        if let Err(why) = check_decode_into(&previous, &msg) {
                            prop_assert!(false, "{}", why);
                        }
                    }
                )*
            }
        }
    };
}

roundtrip_properties! {
    scalars: Scalars,
    texts: Texts,
    nested: Nested,
    arrays: Arrays,
    seqs: Seqs,
    bounded: Bounded,
    nothing: Nothing,
    with_empty: WithEmpty,
    octets: Octets,
    nested_at_1: NestedAt1,
    nested_at_2: NestedAt2,
    nested_at_4: NestedAt4,
    arrays_at_1: ArraysAt1,
    arrays_at_4: ArraysAt4,
    seqs_at_1: SeqsAt1,
    scalars_at_1: ScalarsAt1,
    scalars_at_2: ScalarsAt2,
    texts_at_1: TextsAt1,
    bounded_at_1: BoundedAt1,
    with_empty_at_4: WithEmptyAt4,
}

fn image_strategy() -> impl Strategy<Value = Image> {
    (
        any::<(i32, u32, String, u32, u32, String, u8, u32)>(),
        any::<Vec<u8>>(),
    )
        .prop_map(
            |((sec, nanosec, frame_id, height, width, encoding, is_bigendian, step), data)| Image {
                header: shm_cdr_tests::msgs::Header {
                    stamp: Time { sec, nanosec },
                    frame_id,
                },
                height,
                width,
                encoding,
                is_bigendian,
                step,
                data,
            },
        )
}

proptest! {
    /// The borrowed and owned forms of a message read the same bytes alike.
    #[test]
    fn borrowed_decode_equals_owned(image in image_strategy()) {
        let bytes = shm_cdr::to_vec(&image).unwrap();
        let borrowed: ImageRef = shm_cdr::from_bytes(&bytes).unwrap();
        prop_assert_eq!(&borrowed.header.frame_id, image.header.frame_id.as_str());
        prop_assert_eq!(&borrowed.encoding, image.encoding.as_str());
        prop_assert_eq!(borrowed.data, image.data.as_slice());
        prop_assert_eq!(&shm_cdr::to_vec(&borrowed).unwrap(), &bytes);
        let _: HeaderRef = borrowed.header;
    }

    /// Fixed-layout types report the same size from their compile-time layout as
    /// the writer actually produces, at every start phase.
    #[test]
    fn fixed_layout_matches_writer(arrays in any::<Arrays>(), lead in 0usize..8) {
        use shm_cdr::CdrEncode;
        let layout = Arrays::FIXED_LAYOUT.expect("Arrays has a fixed layout");
        let shifted = (vec![0u8; lead], arrays);
        // Encode `lead` single bytes then the struct, by hand, to reach phase `lead`.
        let mut buf = vec![0u8; 4 + lead + layout.size_at(lead) ];
        let (head, body) = buf.split_at_mut(4);
        head.copy_from_slice(&[0, 1, 0, 0]);
        let mut w = shm_cdr::Writer::<shm_cdr::LittleEndian>::new(body);
        for b in &shifted.0 { b.encode(&mut w).unwrap(); }
        shifted.1.encode(&mut w).unwrap();
        prop_assert_eq!(w.position(), layout.end(lead));
        prop_assert_eq!(shifted.1.encoded_end(lead), layout.end(lead));
    }
}

#[test]
fn fixed_layouts_are_known_at_compile_time() {
    assert!(Scalars::ENCODED_SIZE.is_some());
    assert!(Arrays::ENCODED_SIZE.is_some());
    assert!(Nothing::ENCODED_SIZE == Some(5));
    assert!(Nested::ENCODED_SIZE.is_none());
}

/// Every message type generated into `shm_cdr::msgs` (the registry shm-codegen
/// writes): arbitrary values round-trip exactly in both byte orders, decode over
/// a different earlier value, and the borrowing form (`BorrowedForm::Ref`)
/// decodes the same bytes and re-encodes them unchanged; the type built at
/// run time from its description decodes both byte orders and encodes the
/// same bytes into a buffer holding an earlier message's, none of which
/// survive (every byte of padding written). Values come from `arbitrary`
/// over proptest's bytes, so failures shrink.
mod generated {
    use arbitrary::{Arbitrary, Unstructured};
    use proptest::test_runner::{Config, TestCaseError, TestRunner};
    use shm_cdr::dynamic::DynamicType;
    use shm_cdr::loan::InPlace;
    use shm_cdr::testing::{check_decode_into, check_in_place, check_roundtrip};
    use shm_cdr::{BorrowedForm, DecodeOwned, Endianness};

    /// `encoded` (little-endian) decoded run-time typed from itself and from
    /// `big` (the same message big-endian: its arrays are copied, not
    /// borrowed), each encoded over stale bytes: `encoded` again.
    fn check_dynamic(ty: &DynamicType, encoded: &[u8], big: &[u8]) -> Result<(), TestCaseError> {
        for (order, bytes) in [("little", encoded), ("big", big)] {
            let message = ty
                .decode(bytes)
                .map_err(|e| TestCaseError::fail(format!("run-time typed, {order}-endian: {e}")))?;
            let mut stale = vec![0xA5; encoded.len()];
            let n = shm_cdr::encode_into(&message, &mut stale)
                .map_err(|e| TestCaseError::fail(format!("run-time typed encode: {e}")))?;
            if stale[..n] != *encoded {
                return Err(TestCaseError::fail(format!(
                    "run-time typed, decoded {order}-endian, encodes other bytes"
                )));
            }
        }
        Ok(())
    }

    fn check<T>() -> usize
    where
        T: BorrowedForm + DecodeOwned + InPlace + for<'a> Arbitrary<'a> + std::fmt::Debug,
    {
        let ty = match DynamicType::from_description(&T::full_description()) {
            Ok(ty) => ty,
            Err(e) => panic!("{}: {e}", <T as shm_cdr::RosMessage>::TYPE_NAME),
        };
        let mut runner = TestRunner::new(Config {
            cases: 32,
            failure_persistence: None,
            ..Config::default()
        });
        let built = std::cell::Cell::new(0);
        let bytes = proptest::collection::vec(proptest::prelude::any::<u8>(), 0..4096);
        let result = runner.run(&bytes, |bytes| {
            let mut u = Unstructured::new(&bytes);
            let (Ok(msg), Ok(previous)) = (T::arbitrary(&mut u), T::arbitrary(&mut u)) else {
                return Ok(());
            };
            built.set(built.get() + 1);
            check_roundtrip(&msg).map_err(TestCaseError::fail)?;
            check_decode_into(&previous, &msg).map_err(TestCaseError::fail)?;
            check_in_place(&msg).map_err(|e| TestCaseError::fail(format!("in place: {e}")))?;
            let encoded = shm_cdr::to_vec(&msg).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let view: T::Ref<'_> = shm_cdr::from_bytes(&encoded)
                .map_err(|e| TestCaseError::fail(format!("Ref form: {e}")))?;
            let again = shm_cdr::to_vec(&view).map_err(|e| TestCaseError::fail(e.to_string()))?;
            if again != encoded {
                return Err(TestCaseError::fail("the Ref form re-encodes differently"));
            }
            let big = shm_cdr::to_vec_with(&msg, Endianness::Big)
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            check_dynamic(&ty, &encoded, &big)
        });
        if let Err(e) = result {
            panic!("{}: {e}", <T as shm_cdr::RosMessage>::TYPE_NAME);
        }
        built.get()
    }

    macro_rules! properties {
        (messages: [$($m:path,)*], borrowed: [$(($o:path, $r:path),)*], services: [$($s:path,)*], actions: [$($a:path,)*],) => {
            #[test]
            fn every_generated_message_type() {
                let mut types = 0;
                $(
                    let built = check::<$m>();
                    assert!(built >= 16, "{}: only {built} of 32 values built", stringify!($m));
                    types += 1;
                )*
                assert!(types >= 272, "the registry lists {types} message types");
            }
        };
    }

    shm_cdr::for_each_interface!(properties);
}
