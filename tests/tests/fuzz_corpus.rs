//! Replays the committed cargo-fuzz corpus (`fuzz/corpus/<target>/*`) through the
//! same code the fuzz targets run, so a plain `cargo test` exercises it.

use std::path::Path;

fn replay(target: &str, run: fn(&[u8])) -> usize {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/corpus")
        .join(target);
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        let outcome = std::panic::catch_unwind(|| run(&data));
        assert!(outcome.is_ok(), "corpus input {} fails", path.display());
        count += 1;
    }
    count
}

#[test]
fn decode_corpus() {
    let n = replay("decode", shm_cdr_tests::fuzzing::decode);
    assert!(n >= 10, "only {n} decode corpus inputs");
}

#[test]
fn roundtrip_corpus() {
    let n = replay("roundtrip", shm_cdr_tests::fuzzing::roundtrip);
    assert!(n >= 10, "only {n} roundtrip corpus inputs");
}

#[test]
fn roundtrip_generated_corpus() {
    let n = replay(
        "roundtrip_generated",
        shm_cdr_tests::fuzzing::roundtrip_generated,
    );
    assert!(n >= 272, "only {n} roundtrip_generated corpus inputs");
}

#[test]
fn generated_types_over_the_other_corpora() {
    // The other targets' inputs are arbitrary bytes too.
    let n = replay("roundtrip", shm_cdr_tests::fuzzing::roundtrip_generated)
        + replay("decode", shm_cdr_tests::fuzzing::roundtrip_generated);
    assert!(n >= 20, "only {n} corpus inputs");
}
