//! Parsing a `#[simhc_problem]` module into a [`Declaration`].
//!
//! The declaration is ordinary Rust syntax (so rustfmt and rust-analyzer accept it):
//!
//! ```text
//! #[simhc_problem]                       // or #[simhc_problem(simulator = custom)]
//! pub mod grps {
//!     pub struct Unknowns { q: Quat, t: Vec3, s: Scalar }
//!     pub struct Row { f: Vec3, v: Vec3, fp: Vec3, vp: Vec3 }   // per-correspondence parameters
//!     pub struct Globals { m: Sym<11> }                        // optional global parameters
//!     pub const ROWS: [usize; 2] = [7, 8];                     // one instance per row count
//!     pub fn row_equations() -> Scalar { /* over unknowns, row fields, globals */ }
//!     pub fn global_equations() -> [Scalar; 1] { [q.dot(q) - 1] }
//!     // any other item is passed through unchanged (derived parameters, simulators, tests)
//! }
//! ```

use crate::ctxt::Ctxt;
use proc_macro2::{Span, TokenStream};
use syn::spanned::Spanned;

/// Shape of a declared symbol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// One scalar.
    Scalar,
    /// A vector of the given length (`Vec3`, `Vector<n>`).
    Vector(usize),
    /// A quaternion: a 4-vector that `rotation(q)` accepts.
    Quat,
    /// A general matrix (`Mat<r, c>`, `Mat3`).
    Matrix(usize, usize),
    /// A symmetric matrix (`Sym<n>`): only the upper triangle is a parameter.
    Sym(usize),
}

impl Shape {
    /// Number of scalar variables the symbol occupies.
    pub fn scalar_count(self) -> usize {
        match self {
            Shape::Scalar => 1,
            Shape::Vector(n) => n,
            Shape::Quat => 4,
            Shape::Matrix(r, c) => r * c,
            Shape::Sym(n) => n * (n + 1) / 2,
        }
    }

    /// The Rust type of the symbol in the generated plain-data structs.
    pub fn rust_type(self) -> TokenStream {
        match self {
            Shape::Scalar => quote::quote!(f64),
            Shape::Vector(n) => quote::quote!([f64; #n]),
            Shape::Quat => quote::quote!([f64; 4]),
            Shape::Matrix(r, c) => quote::quote!([[f64; #c]; #r]),
            Shape::Sym(n) => quote::quote!([[f64; #n]; #n]),
        }
    }
}

/// A named symbol of the declaration.
#[derive(Clone, Debug)]
pub struct Field {
    /// Its name in equations.
    pub ident: syn::Ident,
    /// Its shape.
    pub shape: Shape,
    /// Doc attributes carried over to the generated struct.
    pub attrs: Vec<syn::Attribute>,
}

/// An equation function body (`row_equations` or `global_equations`).
#[derive(Clone, Debug)]
pub struct EquationFn {
    /// The function's name, for error spans.
    pub ident: syn::Ident,
    /// Declared number of equations when the return type is `[Scalar; K]`.
    pub declared_count: Option<(usize, Span)>,
    /// The body.
    pub block: syn::Block,
}

/// Options of the attribute itself.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// `simulator = custom`: the problem implements `OnlineSimulator` itself.
    pub custom_simulator: bool,
}

/// A parsed declaration.
#[derive(Clone, Debug)]
pub struct Declaration {
    /// Attribute options.
    pub options: Options,
    /// The module (attributes, visibility, name); its items are in `passthrough`.
    pub module: syn::ItemMod,
    /// Unknowns in declaration order.
    pub unknowns: Vec<Field>,
    /// Per-row parameters.
    pub row_fields: Vec<Field>,
    /// The `Row` struct's identifier, when present.
    pub row_struct: Option<syn::ItemStruct>,
    /// Global parameters.
    pub globals: Vec<Field>,
    /// Row counts to instantiate with their spans (empty when there are no rows).
    pub rows: Vec<(usize, Span)>,
    /// One equation per row (or several: a vector-valued row body).
    pub row_equations: Option<EquationFn>,
    /// Global equations.
    pub global_equations: Option<EquationFn>,
    /// Items copied unchanged into the generated module.
    pub passthrough: Vec<syn::Item>,
}

/// Parses the attribute arguments.
pub fn parse_options(cx: &mut Ctxt, attr: TokenStream) -> Options {
    let mut options = Options::default();
    if attr.is_empty() {
        return options;
    }
    let parser = syn::meta::parser(|meta| {
        if meta.path.is_ident("simulator") {
            let value: syn::Ident = meta.value()?.parse()?;
            if value == "custom" {
                options.custom_simulator = true;
                Ok(())
            } else if value == "generic" {
                Ok(())
            } else {
                Err(syn::Error::new(value.span(), "expected `custom` or `generic`"))
            }
        } else {
            Err(meta.error("unknown simhc_problem option; expected `simulator = custom`"))
        }
    });
    if let Err(e) = syn::parse::Parser::parse2(parser, attr) {
        cx.syn_error(e);
    }
    options
}

/// Parses the module. Returns `None` only when the input is not an inline module at all.
pub fn parse_declaration(cx: &mut Ctxt, options: Options, item: TokenStream) -> Option<Declaration> {
    let module: syn::ItemMod = match syn::parse2(item) {
        Ok(m) => m,
        Err(e) => {
            cx.error_at(e.span(), "#[simhc_problem] goes on an inline module: `mod name { ... }`");
            return None;
        }
    };
    let Some((_, items)) = &module.content else {
        cx.error_spanned_by(&module, "#[simhc_problem] needs an inline module body `{ ... }`");
        return None;
    };
    let mut decl = Declaration {
        options,
        module: syn::ItemMod { content: Some((Default::default(), Vec::new())), ..module.clone() },
        unknowns: Vec::new(),
        row_fields: Vec::new(),
        row_struct: None,
        globals: Vec::new(),
        rows: Vec::new(),
        row_equations: None,
        global_equations: None,
        passthrough: Vec::new(),
    };
    let mut saw_unknowns = false;
    let mut rows_const: Option<syn::ItemConst> = None;
    for item in items {
        match item {
            syn::Item::Struct(s) if s.ident == "Unknowns" => {
                saw_unknowns = true;
                decl.unknowns = parse_fields(cx, s, FieldRole::Unknown);
            }
            syn::Item::Struct(s) if s.ident == "Row" => {
                decl.row_fields = parse_fields(cx, s, FieldRole::Row);
                decl.row_struct = Some(s.clone());
            }
            syn::Item::Struct(s) if s.ident == "Globals" => {
                decl.globals = parse_fields(cx, s, FieldRole::Global);
            }
            syn::Item::Const(c) if c.ident == "ROWS" => {
                decl.rows = parse_rows(cx, c);
                rows_const = Some(c.clone());
            }
            syn::Item::Fn(f) if f.sig.ident == "row_equations" => {
                decl.row_equations = parse_equation_fn(cx, f);
            }
            syn::Item::Fn(f) if f.sig.ident == "global_equations" => {
                decl.global_equations = parse_equation_fn(cx, f);
            }
            other => decl.passthrough.push(other.clone()),
        }
    }
    let name = &module.ident;
    if !saw_unknowns {
        cx.error_spanned_by(name, "a problem needs `struct Unknowns { ... }` declaring its unknowns");
    } else if decl.unknowns.is_empty() {
        cx.error_spanned_by(name, "`Unknowns` declares no unknowns");
    }
    match (&decl.row_struct, &rows_const) {
        (Some(s), None) => cx.error_spanned_by(
            &s.ident,
            "a problem with per-row parameters needs `const ROWS: [usize; K] = [...]`, the row counts to instantiate",
        ),
        (None, Some(c)) => cx.error_spanned_by(&c.ident, "`ROWS` given but no `struct Row` declares per-row parameters"),
        _ => {}
    }
    if decl.row_struct.is_some() && decl.row_equations.is_none() {
        if let Some(s) = &decl.row_struct {
            cx.error_spanned_by(&s.ident, "per-row parameters need `fn row_equations()`");
        }
    }
    if decl.row_struct.is_none() {
        if let Some(f) = &decl.row_equations {
            cx.error_spanned_by(&f.ident, "`row_equations` needs `struct Row { ... }` with per-row parameters");
        }
    }
    if decl.row_equations.is_none() && decl.global_equations.is_none() {
        cx.error_spanned_by(name, "a problem needs `fn row_equations()` and/or `fn global_equations()`");
    }
    check_duplicates(cx, &decl);
    Some(decl)
}

#[derive(Clone, Copy, PartialEq)]
enum FieldRole {
    Unknown,
    Row,
    Global,
}

fn parse_fields(cx: &mut Ctxt, s: &syn::ItemStruct, role: FieldRole) -> Vec<Field> {
    let mut out = Vec::new();
    let syn::Fields::Named(named) = &s.fields else {
        cx.error_spanned_by(&s.ident, "expected a struct with named fields");
        return out;
    };
    for field in &named.named {
        let Some(ident) = field.ident.clone() else { continue };
        let Some(shape) = parse_shape(cx, &field.ty) else { continue };
        let allowed = match role {
            FieldRole::Unknown => matches!(shape, Shape::Scalar | Shape::Vector(_) | Shape::Quat),
            FieldRole::Row => matches!(shape, Shape::Scalar | Shape::Vector(_) | Shape::Quat),
            FieldRole::Global => true,
        };
        if !allowed {
            let what = if role == FieldRole::Unknown { "unknowns" } else { "row fields" };
            cx.error_spanned_by(&field.ty, format!("{what} must be `Scalar`, a vector or `Quat`"));
            continue;
        }
        let attrs = field.attrs.iter().filter(|a| a.path().is_ident("doc")).cloned().collect();
        out.push(Field { ident, shape, attrs });
    }
    out
}

fn parse_usize_expr(e: &syn::Expr) -> Option<usize> {
    match e {
        syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Int(i), .. }) => i.base10_parse().ok(),
        _ => None,
    }
}

fn generic_usizes(cx: &mut Ctxt, seg: &syn::PathSegment, want: usize) -> Option<Vec<usize>> {
    let syn::PathArguments::AngleBracketed(args) = &seg.arguments else {
        cx.error_spanned_by(seg, format!("`{}` needs {want} size argument(s), e.g. `{}<3>`", seg.ident, seg.ident));
        return None;
    };
    let mut sizes = Vec::new();
    for arg in &args.args {
        let n = match arg {
            syn::GenericArgument::Const(e) => parse_usize_expr(e),
            _ => None,
        };
        match n {
            Some(n) if n > 0 => sizes.push(n),
            _ => {
                cx.error_spanned_by(arg, "expected a positive integer literal");
                return None;
            }
        }
    }
    if sizes.len() != want {
        cx.error_spanned_by(args, format!("expected {want} size argument(s)"));
        return None;
    }
    Some(sizes)
}

fn parse_shape(cx: &mut Ctxt, ty: &syn::Type) -> Option<Shape> {
    let syn::Type::Path(tp) = ty else {
        cx.error_spanned_by(ty, "unsupported type; expected Scalar, Vec3, Vector<n>, Quat, Mat<r, c>, Mat3 or Sym<n>");
        return None;
    };
    let Some(seg) = tp.path.segments.last().filter(|_| tp.path.segments.len() == 1) else {
        cx.error_spanned_by(ty, "unsupported type; expected Scalar, Vec3, Vector<n>, Quat, Mat<r, c>, Mat3 or Sym<n>");
        return None;
    };
    let name = seg.ident.to_string();
    let plain = matches!(seg.arguments, syn::PathArguments::None);
    let shape = match name.as_str() {
        "Scalar" | "f64" if plain => Shape::Scalar,
        "Vec2" if plain => Shape::Vector(2),
        "Vec3" if plain => Shape::Vector(3),
        "Vec4" if plain => Shape::Vector(4),
        "Quat" if plain => Shape::Quat,
        "Mat3" if plain => Shape::Matrix(3, 3),
        "Vector" => Shape::Vector(generic_usizes(cx, seg, 1)?[0]),
        "Mat" => {
            let s = generic_usizes(cx, seg, 2)?;
            Shape::Matrix(s[0], s[1])
        }
        "Sym" => Shape::Sym(generic_usizes(cx, seg, 1)?[0]),
        _ => {
            cx.error_spanned_by(ty, "unsupported type; expected Scalar, Vec3, Vector<n>, Quat, Mat<r, c>, Mat3 or Sym<n>");
            return None;
        }
    };
    Some(shape)
}

fn parse_rows(cx: &mut Ctxt, c: &syn::ItemConst) -> Vec<(usize, Span)> {
    let mut out = Vec::new();
    let elems: Vec<&syn::Expr> = match &*c.expr {
        syn::Expr::Array(a) => a.elems.iter().collect(),
        other => vec![other],
    };
    for e in elems {
        match parse_usize_expr(e) {
            Some(n) if n > 0 => {
                if out.iter().any(|&(m, _)| m == n) {
                    cx.error_spanned_by(e, format!("row count {n} listed twice"));
                } else {
                    out.push((n, e.span()));
                }
            }
            _ => cx.error_spanned_by(e, "expected a positive integer literal row count"),
        }
    }
    if out.is_empty() && cx.is_empty() {
        cx.error_spanned_by(&c.expr, "ROWS lists no row counts");
    }
    out
}

fn parse_equation_fn(cx: &mut Ctxt, f: &syn::ItemFn) -> Option<EquationFn> {
    if !f.sig.inputs.is_empty() {
        cx.error_spanned_by(&f.sig.inputs, "equation functions take no arguments: unknowns and parameters are in scope by name");
    }
    let declared_count = match &f.sig.output {
        syn::ReturnType::Type(_, ty) => match &**ty {
            syn::Type::Array(a) => parse_usize_expr(&a.len).map(|n| (n, a.len.span())),
            _ => None,
        },
        syn::ReturnType::Default => None,
    };
    Some(EquationFn { ident: f.sig.ident.clone(), declared_count, block: (*f.block).clone() })
}

fn check_duplicates(cx: &mut Ctxt, decl: &Declaration) {
    let mut seen: Vec<&syn::Ident> = Vec::new();
    for field in decl.unknowns.iter().chain(&decl.row_fields).chain(&decl.globals) {
        if seen.contains(&&field.ident) {
            cx.error_spanned_by(&field.ident, format!("`{}` is declared twice", field.ident));
        } else {
            seen.push(&field.ident);
        }
    }
}
