//! Mistakes are compile errors that point at the user's tokens and say what to do (trybuild
//! `.stderr` files): declaration errors (`ui/`, several at once) and registration errors of
//! `simhc_cli` (`ui/registration/`). One trybuild project checks both, against `simhc-cli`
//! without its `train` feature, so the check does not build burn.
//! After an intended change of messages: `TRYBUILD=overwrite cargo test -p simhc-tests --test compile_fail`.

#[test]
fn declaration_and_registration_errors() {
    let t = trybuild::TestCases::new();
    t.compile_fail("ui/*.rs");
    t.compile_fail("ui/registration/*.rs");
}
