//! The names `emitted_names` reserves (a user's module item may not take them) cover every
//! item the expansion defines in the module, with and without rows.

use quote::quote;
use solvergen::ctxt::Ctxt;

/// The names of the items the expansion of `item` defines in its module, and the names
/// `emitted_names` reserves for it.
fn defined_and_reserved(item: proc_macro2::TokenStream) -> (Vec<String>, Vec<String>) {
    let mut cx = Ctxt::new();
    let options = solvergen::decl::parse_options(&mut cx, quote!());
    let decl = solvergen::decl::parse_declaration(&mut cx, options, item.clone()).expect("a declaration");
    cx.check().expect("no errors");
    let reserved = solvergen::emit::emitted_names(&decl);
    let tokens = solvergen::compile(quote!(), item).expect("expands");
    let module: syn::ItemMod = syn::parse2(tokens).expect("a module");
    let (_, items) = module.content.expect("an inline module");
    let defined = items
        .iter()
        .filter_map(|item| match item {
            syn::Item::Const(i) => Some(i.ident.to_string()),
            syn::Item::Enum(i) => Some(i.ident.to_string()),
            syn::Item::Fn(i) => Some(i.sig.ident.to_string()),
            syn::Item::Mod(i) => Some(i.ident.to_string()),
            syn::Item::Static(i) => Some(i.ident.to_string()),
            syn::Item::Struct(i) => Some(i.ident.to_string()),
            syn::Item::Trait(i) => Some(i.ident.to_string()),
            syn::Item::Type(i) => Some(i.ident.to_string()),
            syn::Item::Union(i) => Some(i.ident.to_string()),
            _ => None,
        })
        .collect();
    (defined, reserved)
}

fn assert_covered(item: proc_macro2::TokenStream, expected: &[&str]) {
    let (defined, reserved) = defined_and_reserved(item);
    for name in expected {
        assert!(defined.iter().any(|d| d == name), "`{name}` is not emitted: {defined:?}");
    }
    for name in &defined {
        assert!(reserved.contains(name), "`{name}` is emitted but not reserved: {reserved:?}");
    }
}

#[test]
fn reserved_names_cover_a_declaration_with_rows() {
    // Square with 2 rows (its `SquareSubsystem2`), not with 3; two or more rows: row kernels.
    assert_covered(
        quote! {
            pub mod line_fit {
                pub struct Unknowns { k: Scalar, m: Scalar }
                pub struct Row { u: Scalar, w: Scalar }
                pub const ROWS: [usize; 2] = [2, 3];
                pub fn row_equations() -> Scalar { k * u + m - w }
            }
        },
        &["NX", "Unknowns", "Row", "__SimhcRowKernels", "LineFit2", "Params3", "AllRoots3", "SquareSubsystem2"],
    );
}

#[test]
fn reserved_names_cover_a_declaration_without_rows() {
    assert_covered(
        quote! {
            pub mod circle_line {
                pub struct Unknowns { x: Vec2 }
                pub struct Globals { c: Vec2, r2: Scalar, a: Vec2, b: Scalar }
                pub fn global_equations() -> [Scalar; 2] {
                    let d = x - c;
                    [d.dot(d) - r2, a.dot(x) - b]
                }
            }
        },
        &["NX", "UnknownVector", "CanonicalFrame", "Refinement", "Unknowns", "Globals", "CircleLine", "Params", "SquareSubsystem"],
    );
}
