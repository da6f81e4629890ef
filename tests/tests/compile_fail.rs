//! Declaration errors point at the user's tokens, several at once (trybuild `.stderr` files).
//! After an intended change of messages: `TRYBUILD=overwrite cargo test -p simhc-tests --test compile_fail`.

#[test]
fn declaration_errors() {
    let t = trybuild::TestCases::new();
    t.compile_fail("ui/*.rs");
}
