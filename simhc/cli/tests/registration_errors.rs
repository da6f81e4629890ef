//! Registration mistakes are compile errors that say what to do (trybuild `.stderr` files).
//! After an intended change of messages: `TRYBUILD=overwrite cargo test -p simhc-cli --test registration_errors`.

#[test]
fn registration_errors() {
    trybuild::TestCases::new().compile_fail("tests/ui/*.rs");
}
