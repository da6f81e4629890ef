//! solvergen: the simhc solver compiler.
//!
//! A `#[simhc_problem]` module (see [`decl`] for the language) goes through
//! parse ([`decl`]) -> validate and lower to sparse polynomials ([`lower`], [`poly`]) and their
//! coefficient form ([`coefficients`]), all at once ([`Lowered`]) -> exact differentiation ->
//! hash-consed DAG with common subexpressions shared ([`dag`]) -> straight-line Rust ([`emit`]),
//! formatted with prettyplease for review and for the checked-in files of a workspace.
//! The batch tracker's row kernel from the parameters skips the expansion: the same evaluator
//! lowers the equations onto DAG nodes ([`lower::Algebra`], [`dag::DagAlgebra`]), differentiated
//! there by reverse mode (`x`-gradient) and forward mode (`dF/dp * dp`).
//!
//! The engine is deterministic: the same declaration gives byte-identical output.

pub mod coefficients;
pub mod constraints;
pub mod ctxt;
pub mod dag;
pub mod decl;
pub mod emit;
pub mod lower;
pub mod poly;
pub mod registration;

use coefficients::CoefficientSplit;
use ctxt::Ctxt;
use proc_macro2::TokenStream;

/// The attribute's expansion: the generated module, or every error found, each at the user's
/// tokens.
pub fn expand(attr: TokenStream, item: TokenStream) -> TokenStream {
    match compile(attr, item) {
        Ok(tokens) => tokens,
        Err(e) => e.to_compile_error(),
    }
}

/// Compiles a declaration, returning all errors combined.
pub fn compile(attr: TokenStream, item: TokenStream) -> Result<TokenStream, syn::Error> {
    let mut cx = Ctxt::new();
    let options = decl::parse_options(&mut cx, attr);
    let Some(decl) = decl::parse_declaration(&mut cx, options, item) else {
        // parse_declaration returns None only after recording an error.
        cx.check()?;
        return Ok(TokenStream::new());
    };
    // Structural errors and equation errors are reported together.
    let probe = lower::check(&mut cx, &decl);
    cx.check()?;
    validate(&mut cx, &decl, &probe);
    cx.check()?;
    Ok(emit::module(&decl, &Lowered::new(&decl)))
}

/// A declaration lowered once: everything [`emit`] renders, so that emission only renders.
#[derive(Debug)]
pub struct Lowered {
    /// One instance per row count of the declaration (a single one without rows).
    pub instances: Vec<Expanded>,
    /// The one row the row kernels are built from, when some instance has two or more rows.
    pub one_row: Option<OneRow>,
}

/// An instance expanded into polynomials, with its coefficient form.
#[derive(Debug)]
pub struct Expanded {
    pub instance: lower::Instance,
    pub coefficients: CoefficientSplit,
}

/// A single row lowered both ways: expanded (the row kernels of the parameter and coefficient
/// forms) and onto a DAG without expansion (the path-lane kernel from the parameters).
#[derive(Debug)]
pub struct OneRow {
    pub expanded: Expanded,
    pub unexpanded: dag::Unexpanded,
}

impl Expanded {
    fn new(decl: &decl::Declaration, rows: usize) -> Self {
        let instance = lower::lower(decl, rows);
        let coefficients = coefficients::split_coefficients(&instance);
        Self { instance, coefficients }
    }
}

impl Lowered {
    /// Lowers a declaration that [`lower::check`] and the size checks accepted.
    pub fn new(decl: &decl::Declaration) -> Self {
        let counts: Vec<usize> = if decl.row_fields.is_empty() { vec![0] } else { decl.rows.iter().map(|&(n, _)| n).collect() };
        let instances: Vec<Expanded> = counts.iter().map(|&n| Expanded::new(decl, n)).collect();
        let one_row = instances.iter().any(|e| e.instance.rows >= 2).then(|| {
            let expanded = Expanded::new(decl, 1);
            let unexpanded = dag::Unexpanded::lower(decl, 1, expanded.instance.vars.nx());
            OneRow { expanded, unexpanded }
        });
        Self { instances, one_row }
    }
}

/// Checks that need the equations: sizes, unused unknowns, vanishing equations.
fn validate(cx: &mut Ctxt, decl: &decl::Declaration, probe: &lower::Instance) {
    let nx = probe.vars.nx();
    let module = &decl.module.ident;
    if decl.row_fields.is_empty() {
        let nf = probe.global_eqs;
        if nf < nx {
            let at = decl.global_equations.as_ref().map(|f| f.ident.clone()).unwrap_or_else(|| module.clone());
            cx.error_spanned_by(at, format!("underdetermined system: {nf} equations in {nx} unknowns"));
        }
    } else {
        for &(n, span) in &decl.rows {
            let nf = n * probe.eqs_per_row + probe.global_eqs;
            if nf < nx {
                cx.error_at(
                    span,
                    format!(
                        "underdetermined system: {n} rows give {nf} equations ({n} x {} + {}) in {nx} unknowns",
                        probe.eqs_per_row, probe.global_eqs
                    ),
                );
            }
        }
    }
    // An unknown absent from every equation makes the Jacobian singular everywhere.
    let mut first_var = 0u32;
    for field in &decl.unknowns {
        let count = field.shape.scalar_count() as u32;
        let range = first_var..first_var + count;
        if !probe.equations.iter().any(|f| f.involves(|v| range.contains(&v))) {
            cx.error_spanned_by(&field.ident, format!("unknown `{}` appears in no equation", field.ident));
        }
        first_var += count;
    }
    // The module's own items must not take the names the expansion emits.
    let emitted = emit::emitted_names(decl);
    for item in &decl.passthrough {
        if let Some(ident) = item_ident(item) {
            if emitted.iter().any(|name| ident == name) {
                cx.error_spanned_by(ident, format!("`{ident}` is a name `#[simhc_problem]` emits in this module; rename this item"));
            }
        }
    }
    for (i, f) in probe.equations.iter().enumerate() {
        if f.is_zero() {
            let at = if i < probe.eqs_per_row { &decl.row_equations } else { &decl.global_equations };
            if let Some(fun) = at {
                cx.error_spanned_by(&fun.ident, "an equation is identically zero");
            }
        }
    }
}

/// The name an item defines in its module, if it defines one.
fn item_ident(item: &syn::Item) -> Option<&syn::Ident> {
    match item {
        syn::Item::Const(i) => Some(&i.ident),
        syn::Item::Enum(i) => Some(&i.ident),
        syn::Item::Fn(i) => Some(&i.sig.ident),
        syn::Item::Mod(i) => Some(&i.ident),
        syn::Item::Static(i) => Some(&i.ident),
        syn::Item::Struct(i) => Some(&i.ident),
        syn::Item::Trait(i) => Some(&i.ident),
        syn::Item::Type(i) => Some(&i.ident),
        syn::Item::Union(i) => Some(&i.ident),
        _ => None,
    }
}

/// The expansion formatted as a file (prettyplease), for snapshots and `generated/`.
pub fn expand_to_string(attr: TokenStream, item: TokenStream) -> Result<String, syn::Error> {
    let tokens = compile(attr, item)?;
    let file: syn::File = syn::parse2(tokens)?;
    Ok(format_file(&file))
}

/// Formats Rust code the way generated files are formatted.
pub fn format_file(file: &syn::File) -> String {
    prettyplease::unparse(file)
}

/// Expands every `#[simhc_problem]` module of a Rust source file into one generated file that
/// starts with `header` (the caller's `// @generated ..` lines, naming the command that
/// regenerates the file). Other items of the source are not included.
pub fn generate_file(source: &str, header: &str) -> Result<String, syn::Error> {
    let file = syn::parse_file(source)?;
    let mut out = String::from(header);
    let mut found = false;
    for item in &file.items {
        let syn::Item::Mod(m) = item else { continue };
        let Some(pos) = m.attrs.iter().position(|a| a.path().segments.last().is_some_and(|s| s.ident == "simhc_problem")) else {
            continue;
        };
        found = true;
        let mut m = m.clone();
        let attr = m.attrs.remove(pos);
        let args = match &attr.meta {
            syn::Meta::List(list) => list.tokens.clone(),
            _ => TokenStream::new(),
        };
        out.push('\n');
        out.push_str(&expand_to_string(args, quote::quote!(#m))?);
    }
    if !found {
        return Err(syn::Error::new(proc_macro2::Span::call_site(), "no #[simhc_problem] module in this file"));
    }
    Ok(out)
}
