//! `compact_str::CompactString` as a `string` field: the same bytes, size,
//! type hash and errors as `String`, by every reader (owned, into a kept
//! value, shared input), and in place.

use compact_str::CompactString;
use shm_cdr::testing::{check_decode_into, check_in_place, check_roundtrip};
use shm_cdr::{
    encoded_size, from_bytes, from_bytes_into, from_shared_bytes, from_shared_bytes_into, to_vec,
    DecodeError, RosMessage,
};
use shm_cdr_tests::msgs::{StringList, StringListCompact};
use shm_cdr_tests::samples;

/// Every place a string can sit: alone, after a byte (so its prefix is
/// padded), in a sequence, in a bounded-length array, nested.
#[derive(RosMessage, Debug, Clone, Default, PartialEq)]
#[ros(type_name = "compact_test/msg/Labels", loan)]
struct Labels {
    flag: u8,
    name: String,
    names: Vec<String>,
    pair: [String; 2],
    list: StringList,
}

#[derive(RosMessage, Debug, Clone, Default, PartialEq)]
#[ros(type_name = "compact_test/msg/Labels", loan)]
struct CompactLabels {
    flag: u8,
    name: CompactString,
    names: Vec<CompactString>,
    pair: [CompactString; 2],
    list: StringListCompact,
}

fn compact(labels: &Labels) -> CompactLabels {
    let list = &labels.list;
    CompactLabels {
        flag: labels.flag,
        name: labels.name.as_str().into(),
        names: labels.names.iter().map(|s| s.as_str().into()).collect(),
        pair: labels.pair.clone().map(CompactString::from),
        list: StringListCompact {
            header: list.header.clone(),
            names: list.names.iter().map(|s| s.as_str().into()).collect(),
        },
    }
}

/// Empty, short, exactly inline-sized, one past it, long, and not ASCII.
fn texts() -> Vec<String> {
    vec![
        String::new(),
        "x".into(),
        "a".repeat(23),
        "b".repeat(24),
        "c".repeat(25),
        "d".repeat(300),
        "ünïcødé ロボット".into(),
        "ß".repeat(20),
    ]
}

fn all_labels() -> Vec<Labels> {
    let texts = texts();
    let mut out = vec![Labels::default()];
    for (i, text) in texts.iter().enumerate() {
        out.push(Labels {
            flag: i as u8,
            name: text.clone(),
            names: texts[..i].to_vec(),
            pair: [
                texts[i % texts.len()].clone(),
                texts[(i + 3) % texts.len()].clone(),
            ],
            list: StringList {
                names: texts[i..].to_vec(),
                ..samples::string_list(i)
            },
        });
    }
    out
}

#[test]
fn writes_sizes_and_hashes_as_string() {
    assert_eq!(CompactLabels::type_hash(), Labels::type_hash());
    assert_eq!(StringListCompact::type_hash(), StringList::type_hash());
    for labels in all_labels() {
        let ours = compact(&labels);
        let bytes = to_vec(&labels).unwrap();
        assert_eq!(to_vec(&ours).unwrap(), bytes, "{labels:?}");
        assert_eq!(encoded_size(&ours), bytes.len());
    }
}

#[test]
fn reads_back_by_every_reader() {
    let all = all_labels();
    let mut kept = CompactLabels::default();
    let mut kept_shared = CompactLabels::default();
    for labels in &all {
        let want = compact(labels);
        let bytes = to_vec(labels).unwrap();
        assert_eq!(from_bytes::<CompactLabels>(&bytes).unwrap(), want);
        assert_eq!(from_shared_bytes::<CompactLabels>(&bytes).unwrap(), want);
        // Into a value holding the previous sample: longer and shorter texts,
        // inline and allocated, in turn.
        from_bytes_into(&bytes, &mut kept).unwrap();
        assert_eq!(kept, want);
        from_shared_bytes_into(&bytes, &mut kept_shared).unwrap();
        assert_eq!(kept_shared, want);
        check_roundtrip(&want).unwrap();
        check_in_place(&want).unwrap();
    }
    for (previous, next) in all.iter().zip(all.iter().rev()) {
        check_decode_into(&compact(previous), &compact(next)).unwrap();
    }
}

/// What a `String` reader says of some input, and what a `CompactString`
/// reader says, by every reader; equal when both fail the same way.
fn both(
    bytes: &[u8],
) -> [(
    Result<Labels, DecodeError>,
    Result<CompactLabels, DecodeError>,
); 2] {
    [
        (from_bytes(bytes), from_bytes(bytes)),
        (from_shared_bytes(bytes), from_shared_bytes(bytes)),
    ]
}

#[test]
fn refuses_what_string_refuses_with_the_same_error() {
    let labels = &all_labels()[7];
    let bytes = to_vec(labels).unwrap();
    let mut checked = 0;
    let mut inputs: Vec<Vec<u8>> = (0..bytes.len()).map(|n| bytes[..n].to_vec()).collect();
    for at in 4..bytes.len() {
        for bad in [0x00, 0x80, 0xc3, 0xff] {
            let mut damaged = bytes.clone();
            damaged[at] = bad;
            inputs.push(damaged);
        }
    }
    for input in &inputs {
        for (string, compact_result) in both(input) {
            match (string, compact_result) {
                (Ok(s), Ok(c)) => assert_eq!(compact(&s), c),
                (Err(s), Err(c)) => {
                    // The same offset, field and reason; only the structs'
                    // Rust names differ.
                    let c = c
                        .to_string()
                        .replace("CompactLabels", "Labels")
                        .replace("StringListCompact", "StringList");
                    assert_eq!(s.to_string(), c);
                    checked += 1;
                }
                (s, c) => panic!("String {s:?}, CompactString {c:?} on {input:?}"),
            }
        }
    }
    // Truncations alone fail: the check compared errors, not only successes.
    assert!(checked >= 2 * bytes.len(), "{checked} errors compared");
}

#[test]
fn a_refused_string_leaves_the_kept_value_as_it_was() {
    let labels = &all_labels()[3];
    let mut bytes = to_vec(labels).unwrap();
    let want = compact(labels);
    // The name's first byte (after the 4-byte header, the flag, padding and
    // the length prefix) made a stray continuation byte.
    let name_at = 4 + 4 + 4;
    assert_eq!(
        &bytes[name_at..name_at + labels.name.len()],
        labels.name.as_bytes()
    );
    bytes[name_at] = 0x80;
    for shared in [false, true] {
        let mut kept = want.clone();
        let outcome = match shared {
            false => from_bytes_into(&bytes, &mut kept),
            true => from_shared_bytes_into(&bytes, &mut kept),
        };
        assert!(outcome.unwrap_err().to_string().contains("UTF-8"));
        assert_eq!(kept.name, want.name);
    }
}
