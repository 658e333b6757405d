//! Byte equality before timing: every peer must write exactly our bytes for a
//! message, read our bytes back into the same value, and (where it has one)
//! compute the right size. A peer that fails any of these on a message is
//! reported and left out of that message's timings.

use crate::messages::{Message, Sample};
use crate::mirror;
use crate::peers::{cdr_crate, cdr_encoding, hiroz};

/// The peer libraries, by the names the report uses.
pub const HIROZ: &str = "hiroz-cdr";
/// The `cdr` crate.
pub const CDR: &str = "cdr";
/// The `cdr-encoding` crate.
pub const CDR_ENCODING: &str = "cdr-encoding";
/// eProsima Fast-CDR through the C++ shim.
pub const FAST_CDR: &str = "Fast-CDR";

/// What checking one library on one message found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Verdict {
    /// Library name.
    pub library: &'static str,
    /// Message name.
    pub message: &'static str,
    /// Everything that disagreed with shm-cdr; empty when the library agrees.
    pub problems: Vec<String>,
}

impl Verdict {
    /// The library wrote and read exactly what we do.
    pub fn agrees(&self) -> bool {
        self.problems.is_empty()
    }
}

/// Where two encodings first differ, for the report.
fn compare(ours: &[u8], theirs: &[u8]) -> Option<String> {
    if ours == theirs {
        return None;
    }
    let at = ours
        .iter()
        .zip(theirs)
        .position(|(a, b)| a != b)
        .unwrap_or(ours.len().min(theirs.len()));
    let byte = |b: &[u8]| b.get(at).map_or("end".to_string(), |v| format!("{v:#04x}"));
    Some(format!(
        "encode: {} bytes (ours {}), first difference at byte {at}: {} instead of {}",
        theirs.len(),
        ours.len(),
        byte(theirs),
        byte(ours)
    ))
}

/// Check a Rust peer given its encode / decode / size functions.
fn check_rust_peer<P: PartialEq>(
    library: &'static str,
    message: &'static str,
    ours: &[u8],
    value: &P,
    encode: impl Fn(&P) -> Result<Vec<u8>, String>,
    decode: impl Fn(&[u8]) -> Result<P, String>,
    size: Option<&dyn Fn(&P) -> usize>,
) -> Verdict {
    let mut problems = Vec::new();
    match encode(value) {
        Ok(theirs) => problems.extend(compare(ours, &theirs)),
        Err(e) => problems.push(format!("encode failed: {e}")),
    }
    match decode(ours) {
        Ok(decoded) if decoded == *value => {}
        Ok(_) => problems.push("decode: our bytes read back as a different value".into()),
        Err(e) => problems.push(format!("decode of our bytes failed: {e}")),
    }
    if let Some(size) = size {
        let said = size(value);
        if said != ours.len() {
            problems.push(format!("size: says {said}, the encoding is {}", ours.len()));
        }
    }
    Verdict {
        library,
        message,
        problems,
    }
}

/// Check every peer on one message.
pub fn check<M: Message>(sample: &Sample<M>) -> Vec<Verdict> {
    let ours = shm_cdr::to_vec(&sample.msg).expect("the sample messages are within CDR limits");
    let value: M::Mirror = sample.msg.mirror();
    let name = sample.name;
    let mut verdicts = vec![
        check_rust_peer(
            HIROZ,
            name,
            &ours,
            &value,
            |v| Ok(hiroz::to_vec(v)),
            hiroz::decode::<M::Mirror>,
            Some(&hiroz::size::<M::Mirror>),
        ),
        check_rust_peer(
            CDR,
            name,
            &ours,
            &value,
            cdr_crate::to_vec,
            cdr_crate::decode::<M::Mirror>,
            Some(&cdr_crate::size::<M::Mirror>),
        ),
        check_rust_peer(
            CDR_ENCODING,
            name,
            &ours,
            &value,
            cdr_encoding::to_vec,
            cdr_encoding::decode::<M::Mirror>,
            None,
        ),
    ];
    verdicts.extend(check_fast_cdr::<M>(name, &ours));
    verdicts
}

/// Fast-CDR: decode our bytes, re-encode into a zeroed buffer (Fast-CDR does
/// not write its alignment padding; zeroes there match ours), compare bytes
/// and the size function. `None` when the shim was not built.
#[cfg(fastcdr)]
fn check_fast_cdr<M: Message>(message: &'static str, ours: &[u8]) -> Option<Verdict> {
    use crate::fastcdr::FastMsg;
    let mut problems = Vec::new();
    match FastMsg::load(M::fast_cdr(), ours) {
        None => problems.push("decode of our bytes failed".into()),
        Some(msg) => {
            let mut out = vec![0u8; ours.len() + 64];
            match msg.encode(&mut out) {
                Some(n) => problems.extend(compare(ours, &out[..n])),
                None => problems.push("encode failed".into()),
            }
            if msg.size() != ours.len() {
                problems.push(format!(
                    "size: says {}, the encoding is {}",
                    msg.size(),
                    ours.len()
                ));
            }
        }
    }
    Some(Verdict {
        library: FAST_CDR,
        message,
        problems,
    })
}

#[cfg(not(fastcdr))]
#[allow(clippy::extra_unused_type_parameters)] // same signature as the built variant
fn check_fast_cdr<M: Message>(_message: &'static str, _ours: &[u8]) -> Option<Verdict> {
    None
}

/// hiroz-cdr's bulk path on `{Time stamp; float64 value}[]`: `write_pod_slice`
/// aligns the first element to Rust's `align_of` (8) and copies the 16-byte
/// memory layout, where CDR starts the element at 4 and pads before `value`.
pub fn check_hiroz_bulk(sample: &Sample<crate::messages::StampedValues>) -> Verdict {
    let ours = shm_cdr::to_vec(&sample.msg).expect("within CDR limits");
    let value = mirror::StampedValuesBulk::from(&sample.msg.mirror());
    check_rust_peer(
        "hiroz-cdr (bulk path)",
        sample.name,
        &ours,
        &value,
        |v| Ok(hiroz::to_vec(v)),
        hiroz::decode::<mirror::StampedValuesBulk>,
        Some(&hiroz::size::<mirror::StampedValuesBulk>),
    )
}

/// Every message of the comparison, checked against every peer, then the
/// hiroz bulk-path case.
pub fn check_all() -> Vec<Verdict> {
    use crate::messages::samples::*;
    let mut all = check(&header_small());
    for cloud in point_clouds() {
        all.extend(check(&cloud));
    }
    all.extend(check(&image_1080p()));
    all.extend(check(&joint_state()));
    all.extend(check(&pose_array()));
    all.extend(check(&string_list()));
    let stamped = stamped_values();
    all.extend(check(&stamped));
    all.push(check_hiroz_bulk(&stamped));
    all
}
