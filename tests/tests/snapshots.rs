//! Snapshots of the built-in expansions. UPnP is snapshotted whole; GRPS (about 27,000 lines for
//! its two instances) is snapshotted as a digest of every generated function (statement count)
//! plus the whole residual of the minimal instance, while its full text is reviewed in
//! `generated/grps.rs`, which `generated.rs` keeps current. Review changes with
//! `cargo insta review` (or `INSTA_UPDATE=always cargo test -p simhc-tests --test snapshots`).

use std::path::Path;

fn expansion(src: &str) -> syn::File {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let source = std::fs::read_to_string(root.join(src)).unwrap_or_else(|e| panic!("{src}: {e}"));
    let text = solvergen::generate_file(&source, xtask::HEADER).unwrap_or_else(|e| panic!("{src}: {e}"));
    syn::parse_file(&text).unwrap_or_else(|e| panic!("generated code does not parse: {e}"))
}

/// One line per generated function: `impl target :: fn name : statements`.
fn digest(file: &syn::File) -> String {
    let mut out = String::new();
    let mut visit = |items: &[syn::Item]| {
        for item in items {
            let syn::Item::Impl(imp) = item else { continue };
            let ty = &imp.self_ty;
            let target = quote::quote!(#ty).to_string();
            let tr = imp.trait_.as_ref().map(|(_, p, _)| p.segments.last().map(|s| s.ident.to_string()).unwrap_or_default());
            for it in &imp.items {
                if let syn::ImplItem::Fn(f) = it {
                    out.push_str(&format!(
                        "{target} {} :: {} : {} statements\n",
                        tr.clone().unwrap_or_else(|| "inherent".into()),
                        f.sig.ident,
                        f.block.stmts.len()
                    ));
                }
            }
        }
    };
    for item in &file.items {
        if let syn::Item::Mod(m) = item {
            if let Some((_, items)) = &m.content {
                visit(items);
            }
        }
    }
    out
}

#[test]
fn upnp_expansion() {
    let file = expansion("problems/src/upnp/system.rs");
    insta::assert_snapshot!(prettyplease_unparse(&file));
}

#[test]
fn grps_expansion_digest() {
    let file = expansion("problems/src/grps/system.rs");
    insta::assert_snapshot!("grps_digest", digest(&file));
    // The whole residual of the minimal instance.
    let mut residual = String::new();
    for item in &file.items {
        let syn::Item::Mod(m) = item else { continue };
        for it in m.content.iter().flat_map(|(_, items)| items) {
            let syn::Item::Impl(imp) = it else { continue };
            let ty = &imp.self_ty;
            let is_grps7 = quote::quote!(#ty).to_string().contains("Grps7");
            let is_problem = imp.trait_.as_ref().is_some_and(|(_, p, _)| p.segments.last().is_some_and(|s| s.ident == "Problem"));
            if is_grps7 && is_problem {
                for f in &imp.items {
                    if let syn::ImplItem::Fn(f) = f {
                        if f.sig.ident == "residual" {
                            residual = quote::quote!(#f).to_string();
                        }
                    }
                }
            }
        }
    }
    let file: syn::File = syn::parse_str(&format!("impl X {{ {residual} }}")).expect("parses");
    insta::assert_snapshot!("grps7_residual", prettyplease_unparse(&file));
}

fn prettyplease_unparse(file: &syn::File) -> String {
    // Formatting goes through the same path as the generator.
    let tokens = quote::quote!(#file);
    let reparsed: syn::File = syn::parse2(tokens).expect("reparses");
    solvergen_unparse(&reparsed)
}

fn solvergen_unparse(file: &syn::File) -> String {
    solvergen::format_file(file)
}

/// The layout metadata (`ProblemLayout`) of a declaration with every kind of field, rows and
/// globals, snapshotted on its own (generic code such as the learned start reads it).
#[test]
fn layout_metadata_of_every_kind() {
    let source = r#"
        #[simhc::simhc_problem]
        mod every_kind {
            pub struct Unknowns { q: Quat, t: Vec3, s: Scalar, w: Vector<2> }
            pub struct Row { f: Vec3, g: Quat, h: Scalar }
            pub struct Globals { k: Mat3, m: Sym<3>, c: Scalar }
            pub const ROWS: [usize; 2] = [3, 4];
            pub fn row_equations() -> Vec3 {
                f.cross(s * (rotation(q) * t) + k * t) + c * f + h * g.dot(q) * t
            }
            pub fn global_equations() -> [Scalar; 4] {
                [q.dot(q) - 1, t.dot(m * t) - 1, w[0] - s, w[1] + s]
            }
        }
    "#;
    let text = solvergen::generate_file(source, xtask::HEADER).unwrap_or_else(|e| panic!("{e}"));
    let file = syn::parse_file(&text).expect("generated code parses");
    let mut layouts = Vec::new();
    for item in &file.items {
        let syn::Item::Mod(m) = item else { continue };
        for it in m.content.iter().flat_map(|(_, items)| items) {
            let syn::Item::Impl(imp) = it else { continue };
            if imp.trait_.as_ref().is_some_and(|(_, p, _)| p.segments.last().is_some_and(|s| s.ident == "ProblemLayout")) {
                layouts.push(syn::Item::Impl(imp.clone()));
            }
        }
    }
    assert_eq!(layouts.len(), 2, "one layout per instance (3 and 4 rows)");
    let file = syn::File { shebang: None, attrs: vec![], items: layouts };
    insta::assert_snapshot!("layout_every_kind", prettyplease_unparse(&file));
}
