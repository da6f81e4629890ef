//! `#[simhc::declared_problem]` on an `impl DeclaredProblem for Foo` block, and on the same
//! type's `impl Scenes for Foo` block: the traits' five sizes come from the first impl's own
//! `type Tracked` and `type Data`, so user code writes no number.
//!
//! `impl DeclaredProblem for P { type Tracked = T; type Data = D; .. }` becomes
//! `impl DeclaredProblem<{ T::NX }, { T::NF }, { T::NP }, { T::NC }, { D::NP }> for P { .. }`,
//! each size spanned by the user's `T` or `D`, so a type that is no compiled instance is an error
//! on that line, and `impl DeclaredSizes for P { const SIZES: [usize; 5] = [T::NX, .., D::NP]; }`.
//! `impl Scenes for P { .. }` becomes `impl Scenes<{ <P as DeclaredSizes>::SIZES[0] }, ..> for P`:
//! a trait impl's const arguments cannot be read back, so `DeclaredSizes` carries them from one
//! impl to the other. `fn plan(&self) -> Plan` gets the same sizes:
//! `Plan<SVector<f64, { D::NP }>, { T::NX }, { T::NF }, { T::NP }>`. Every mistake of a block is
//! reported at once.

use crate::ctxt::Ctxt;
use proc_macro2::TokenStream;
use quote::{quote, quote_spanned};
use syn::spanned::Spanned;

/// Expands the attribute; errors become `compile_error!`s at the user's tokens.
pub fn expand(attr: TokenStream, item: TokenStream) -> TokenStream {
    match declared_problem(attr, item) {
        Ok(tokens) => tokens,
        Err(e) => e.to_compile_error(),
    }
}

/// The names of the sizes, in the traits' order (that of `DeclaredSizes::SIZES`).
const SIZE_NAMES: [&str; 5] = ["NX", "NF", "NP", "NC", "ND"];

/// The impl block with the trait's sizes filled in, or every error found.
pub fn declared_problem(attr: TokenStream, item: TokenStream) -> Result<TokenStream, syn::Error> {
    let mut cx = Ctxt::new();
    if !attr.is_empty() {
        cx.error_spanned_by(&attr, "`#[declared_problem]` takes no arguments: the sizes come from `type Tracked` and `type Data`");
    }
    let mut block: syn::ItemImpl = syn::parse2(item)?;
    let Some((_, trait_path, _)) = block.trait_.as_ref() else {
        return Err(syn::Error::new(
            block.self_ty.span(),
            "`#[declared_problem]` goes on `impl simhc::solver::DeclaredProblem for YourProblem { .. }` or `impl simhc::solver::Scenes for YourProblem { .. }`",
        ));
    };
    let last = trait_path.segments.last().expect("a parsed path has a segment");
    // A `Scenes` impl reads the sizes that the type's `DeclaredProblem` impl writes.
    let scenes = last.ident == "Scenes";
    let sizes = if scenes { None } else { Some(instance_sizes(&mut cx, &block)) };
    if !last.arguments.is_none() {
        cx.error_spanned_by(&last.arguments, "remove the sizes: `#[declared_problem]` fills them in from `type Tracked` and `type Data`");
    }
    if let Some(sizes) = &sizes {
        size_the_plan(&mut cx, &mut block, sizes);
    }
    cx.check()?;
    let self_ty = &block.self_ty;
    let (args, sizes_impl) = match sizes {
        // The `DeclaredProblem` impl names the instances' sizes themselves, not those of its
        // `DeclaredSizes` impl: they do not depend on the impl's generics, so a generic problem
        // type stays sized (a const argument may not use a generic parameter).
        Some(sizes) => {
            let (impl_generics, _, where_clause) = block.generics.split_for_impl();
            let sizes_impl = quote! {
                impl #impl_generics ::simhc::solver::DeclaredSizes for #self_ty #where_clause {
                    const SIZES: [usize; 5] = [#(#sizes),*];
                }
            };
            (sizes.map(|size| quote!({ #size })).to_vec(), Some(sizes_impl))
        }
        None => {
            let read =
                (0..SIZE_NAMES.len()).map(|k| quote_spanned!(self_ty.span()=> { <#self_ty as ::simhc::solver::DeclaredSizes>::SIZES[#k] }));
            (read.collect(), None)
        }
    };
    let (_, trait_path, _) = block.trait_.as_mut().expect("checked");
    let last = trait_path.segments.last_mut().expect("a parsed path has a segment");
    last.arguments = syn::PathArguments::AngleBracketed(syn::parse2(quote!(<#(#args),*>))?);
    Ok(quote!(#sizes_impl #block))
}

/// `fn plan(&self) -> Plan` of a `DeclaredProblem` block returns the plan of the problem's
/// sizes, `Plan<SVector<f64, ND>, NX, NF, NP>`, spanned by the user's `Plan`.
fn size_the_plan(cx: &mut Ctxt, block: &mut syn::ItemImpl, sizes: &[TokenStream; 5]) {
    let [nx, nf, np, _, nd] = sizes;
    for item in &mut block.items {
        let syn::ImplItem::Fn(f) = item else { continue };
        if f.sig.ident != "plan" {
            continue;
        }
        let syn::ReturnType::Type(_, ty) = &mut f.sig.output else { continue };
        let syn::Type::Path(path) = ty.as_mut() else { continue };
        let Some(last) = path.path.segments.last() else { continue };
        if last.ident != "Plan" {
            continue;
        }
        if !last.arguments.is_none() {
            cx.error_spanned_by(
                &last.arguments,
                "write `-> Plan`: `#[declared_problem]` fills in the sizes from `type Tracked` and `type Data`",
            );
            continue;
        }
        let span = last.ident.span();
        **ty = syn::parse_quote_spanned!(span=> ::simhc::solver::Plan<::simhc::__private::nalgebra::SVector<f64, { #nd }>, { #nx }, { #nf }, { #np }>);
    }
}

/// The five sizes of a `DeclaredProblem` block, `[T::NX, T::NF, T::NP, T::NC, D::NP]` of its
/// `type Tracked = T` and `type Data = D`, each spanned by the user's type (an error on the
/// trait for each type missing, and then no sizes).
fn instance_sizes(cx: &mut Ctxt, block: &syn::ItemImpl) -> [TokenStream; 5] {
    let associated = |name: &str| {
        block.items.iter().find_map(|item| match item {
            syn::ImplItem::Type(t) if t.ident == name => Some(t.ty.clone()),
            _ => None,
        })
    };
    let (tracked, data) = (associated("Tracked"), associated("Data"));
    let anchor = &block.trait_.as_ref().expect("a trait impl").1;
    for (found, name) in [(&tracked, "Tracked"), (&data, "Data")] {
        if found.is_none() {
            cx.error_spanned_by(
                anchor,
                format!("missing `type {name} = ..;`: `#[declared_problem]` takes the sizes from `type Tracked` and `type Data`"),
            );
        }
    }
    let (Some(tracked), Some(data)) = (tracked, data) else {
        return Default::default();
    };
    // The data instance's parameter count is its `NP`: the trait's `ND`.
    SIZE_NAMES.map(|name| {
        let (ty, from) = if name == "ND" { (&data, "NP") } else { (&tracked, name) };
        let from = syn::Ident::new(from, ty.span());
        quote_spanned!(ty.span()=> <#ty>::#from)
    })
}

#[cfg(test)]
mod tests {
    use super::declared_problem;
    use quote::quote;

    #[test]
    fn the_plan_gets_the_problems_sizes() {
        let item = quote! {
            impl DeclaredProblem for P {
                type Tracked = Foo6;
                type Data = Foo7;
                fn plan(&self) -> Plan { Plan::default() }
            }
        };
        let out = declared_problem(quote!(), item).expect("expands").to_string().replace(' ', "");
        assert!(
            out.contains(
                "fnplan(&self)->::simhc::solver::Plan<::simhc::__private::nalgebra::SVector<f64,{<Foo7>::NP}>,{<Foo6>::NX},{<Foo6>::NF},{<Foo6>::NP}>"
            ),
            "{out}"
        );
    }

    #[test]
    fn a_plan_with_sizes_is_an_error_at_them() {
        let item = quote! {
            impl DeclaredProblem for P {
                type Tracked = Foo6;
                type Data = Foo7;
                fn plan(&self) -> simhc::solver::Plan<V, 7, 7, 72> { Plan::default() }
            }
        };
        let e = declared_problem(quote!(), item).expect_err("sizes written by hand");
        assert!(e.to_string().contains("write `-> Plan`"), "{e}");
    }
}
