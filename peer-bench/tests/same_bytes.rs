//! Before anything is timed: which peers write and read exactly our bytes (our
//! bytes are proven equal to rosbags' and pycdr2's in `shm-cdr-tests`).

use shm_cdr_peer_bench::check::{self, CDR, CDR_ENCODING, FAST_CDR, HIROZ};
use shm_cdr_peer_bench::check_all;

#[test]
fn every_peer_agrees_on_every_message_except_the_known_findings() {
    let verdicts = check_all();
    for v in &verdicts {
        println!("{:<22} {:<20} {:?}", v.library, v.message, v.problems);
    }
    let disagreeing: Vec<_> = verdicts
        .iter()
        .filter(|v| !v.agrees() && v.library != "hiroz-cdr (bulk path)")
        .collect();
    assert!(
        disagreeing.is_empty(),
        "unexpected disagreements: {disagreeing:#?}"
    );
    // Every Rust peer was checked on all 8 messages.
    for library in [HIROZ, CDR, CDR_ENCODING] {
        assert_eq!(verdicts.iter().filter(|v| v.library == library).count(), 8);
    }
    let fast_cdr = verdicts.iter().filter(|v| v.library == FAST_CDR).count();
    if cfg!(fastcdr) {
        assert_eq!(fast_cdr, 8);
    } else {
        println!("Fast-CDR not built (see build.rs): its column is skipped");
    }
}

#[test]
fn hiroz_bulk_path_writes_memory_layout_for_stamped_values() {
    let sample = shm_cdr_peer_bench::samples::stamped_values();
    let verdict = check::check_hiroz_bulk(&sample);
    // The finding: `write_pod_slice` pads the u32 count to Rust's align_of (8)
    // and copies 16-byte elements; CDR puts the first stamp right after the
    // count (offset 4 of the body) and pads 4 bytes before each `value`.
    assert!(
        !verdict.agrees(),
        "hiroz's bulk path now matches CDR: update the README finding"
    );
    assert!(
        verdict.problems.iter().any(|p| p.starts_with("encode:")),
        "{verdict:?}"
    );
}
