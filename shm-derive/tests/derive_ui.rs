//! Compile-pass and compile-fail tests of `#[derive(RosMessage)]`: every rejected
//! input points at the offending item and says what to write instead.

#[test]
fn derive_ui() {
    let t = trybuild::TestCases::new();
    t.pass("tests/ui/pass/*.rs");
    t.compile_fail("tests/ui/fail/*.rs");
}
