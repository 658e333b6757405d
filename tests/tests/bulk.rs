//! The bulk-copy path for sequences of structs: taken exactly where the CDR layout
//! equals the memory layout, and byte-identical to element-by-element encoding at
//! every start phase.

use shm_cdr::{CdrDecode, CdrEncode, LittleEndian, Reader, RosMessage, Writer};
use shm_cdr_tests::msgs::{Point, Pose, Time};

#[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
#[ros(package = "bulk_test")]
#[repr(C)]
struct Stamped {
    stamp: Time,
    value: f64,
}

#[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
#[ros(package = "bulk_test")]
struct PairU32 {
    a: u32,
    b: u32,
}

#[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
#[ros(package = "bulk_test")]
struct Padded {
    a: u8,
    b: f64,
}

#[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
#[ros(package = "bulk_test")]
struct WithBool {
    a: bool,
    b: u8,
}

fn plain<T: CdrEncode>() -> Option<(usize, usize)> {
    T::PLAIN.map(|p| (p.align(), p.first_align()))
}

#[test]
fn plain_only_where_memory_is_the_wire() {
    assert_eq!(plain::<Point>(), Some((8, 8)));
    assert_eq!(plain::<Pose>(), Some((8, 8)));
    // {i32, u32} then f64: packed in memory, equal to CDR only at phase 0 mod 8.
    assert_eq!(plain::<Stamped>(), Some((8, 4)));
    assert_eq!(plain::<PairU32>(), Some((4, 4)));
    assert_eq!(plain::<[Pose; 3]>(), Some((8, 8)));
    // Rust padding bytes are uninitialized and CDR's are zero: never copied.
    assert_eq!(plain::<Padded>(), None);
    // Not every byte is a valid bool.
    assert_eq!(plain::<WithBool>(), None);
    assert_eq!(plain::<shm_cdr_tests::msgs::Header>(), None);
    // Without #[repr(C)] the proof follows whatever order rustc chose: correct
    // either way, bulk only if the order happens to be CDR's.
    #[derive(RosMessage)]
    #[ros(package = "bulk_test")]
    struct Reorderable {
        small: u32,
        big: Pose,
        other: u32,
    }
    let in_order = std::mem::offset_of!(Reorderable, small) == 0
        && std::mem::offset_of!(Reorderable, big) == 8;
    if !in_order {
        assert_eq!(plain::<Reorderable>(), None);
    }
}

/// Encode `lead` bytes, then `items` as a sequence, once through `Vec`'s slice
/// path and once element by element.
fn both_ways<T: CdrEncode>(items: &[T], lead: usize) -> (Vec<u8>, Vec<u8>) {
    let size = T::slice_encoded_end(items, shm_cdr::layout::align_up(lead, 4) + 4);
    let run = |bulk: bool| {
        let mut buf = vec![0xCC; size];
        let mut w = Writer::<LittleEndian>::new(&mut buf);
        for _ in 0..lead {
            0u8.encode(&mut w).unwrap();
        }
        w.write_len(items.len()).unwrap();
        if bulk {
            T::encode_slice(items, &mut w).unwrap();
        } else {
            for item in items {
                item.encode(&mut w).unwrap();
            }
        }
        assert_eq!(w.position(), size);
        buf
    };
    (run(true), run(false))
}

#[test]
fn bulk_equals_element_by_element_at_every_phase() {
    let stamped: Vec<Stamped> = (0..5)
        .map(|i| Stamped {
            stamp: Time { sec: i, nanosec: 7 },
            value: f64::from(i) * 0.25,
        })
        .collect();
    let pairs: Vec<PairU32> = (0..5).map(|i| PairU32 { a: i, b: !i }).collect();
    let poses = shm_cdr_tests::samples::pose_array(5).poses;
    for lead in 0..16 {
        let (bulk, single) = both_ways(&stamped, lead);
        assert_eq!(bulk, single, "Stamped at lead {lead}");
        let (bulk, single) = both_ways(&pairs, lead);
        assert_eq!(bulk, single, "PairU32 at lead {lead}");
        let (bulk, single) = both_ways(&poses, lead);
        assert_eq!(bulk, single, "Pose at lead {lead}");

        // And decoding it back (bulk or not) gives the values.
        let mut r = Reader::<LittleEndian>::new(&bulk);
        for _ in 0..lead {
            let _: u8 = u8::decode(&mut r).unwrap();
        }
        let back: Vec<Pose> = Vec::decode(&mut r).unwrap();
        assert_eq!(back, poses);
    }
}
