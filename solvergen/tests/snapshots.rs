//! Snapshots of the emitted code for small problems: review changes with `cargo insta review`.

use quote::quote;

fn expand(attr: proc_macro2::TokenStream, item: proc_macro2::TokenStream) -> String {
    solvergen::expand_to_string(attr, item).unwrap_or_else(|e| panic!("expansion failed: {e}"))
}

#[test]
fn circle_line() {
    let out = expand(
        quote!(),
        quote! {
            /// Intersection of the circle |x - c|^2 = r2 with the line a.x = b.
            pub mod circle_line {
                pub struct Unknowns { x: Vec2 }
                pub struct Globals { c: Vec2, r2: Scalar, a: Vec2, b: Scalar }
                pub fn global_equations() -> [Scalar; 2] {
                    let d = x - c;
                    [d.dot(d) - r2, a.dot(x) - b]
                }
            }
        },
    );
    insta::assert_snapshot!(out);
}

#[test]
fn p3p_like() {
    // Distances between three points on rays with unknown depths: the P3P system.
    let out = expand(
        quote!(),
        quote! {
            pub mod p3p {
                pub struct Unknowns { d: Vec3 }
                pub struct Globals { f1: Vec3, f2: Vec3, f3: Vec3, s: Vec3 }
                pub fn global_equations() -> [Scalar; 3] {
                    let a = d[0] * f1;
                    let b = d[1] * f2;
                    let c = d[2] * f3;
                    [(a - b).norm_squared() - s[0], (b - c).norm_squared() - s[1], (a - c).norm_squared() - s[2]]
                }
            }
        },
    );
    insta::assert_snapshot!(out);
}

#[test]
fn rows_instantiate_per_count() {
    let out = expand(
        quote!(simulator = custom),
        quote! {
            pub mod line_fit {
                pub struct Unknowns { k: Scalar, m: Scalar }
                pub struct Row { u: Scalar, w: Scalar }
                pub const ROWS: [usize; 2] = [2, 3];
                pub fn row_equations() -> Scalar { k * u + m - w }
            }
        },
    );
    assert!(out.contains("pub struct LineFit2;") && out.contains("pub struct LineFit3;"));
    assert!(!out.contains("OnlineSimulator"), "simulator = custom must drop the default");
    insta::assert_snapshot!(out);
}

#[test]
fn output_is_deterministic() {
    let item = quote! {
        pub mod twice {
            pub struct Unknowns { q: Quat, t: Vec3 }
            pub struct Row { f: Vec3, g: Vec3 }
            pub const ROWS: [usize; 1] = [6];
            pub fn row_equations() -> Scalar { t.dot(f.cross(rotation(q) * g)) }
            pub fn global_equations() -> Scalar { q.dot(q) - 1 }
        }
    };
    assert_eq!(expand(quote!(), item.clone()), expand(quote!(), item));
}
