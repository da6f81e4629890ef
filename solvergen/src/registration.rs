//! `#[simhc::declared_problem]` on an `impl DeclaredProblem for Foo` block: the trait's five
//! sizes come from the impl's own `type Tracked` and `type Data`, so user code writes no number.
//!
//! `impl DeclaredProblem for P { type Tracked = T; type Data = D; .. }` becomes
//! `impl DeclaredProblem<{ T::NX }, { T::NF }, { T::NP }, { T::NC }, { D::NP }> for P { .. }`,
//! each size spanned by the user's `T` or `D`, so a type that is no compiled instance is an error
//! on that line. Every mistake of the block is reported at once.

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

/// The impl block with the trait's sizes filled in, or every error found.
pub fn declared_problem(attr: TokenStream, item: TokenStream) -> Result<TokenStream, syn::Error> {
    let mut cx = Ctxt::new();
    if !attr.is_empty() {
        cx.error_spanned_by(&attr, "`#[declared_problem]` takes no arguments: the sizes come from `type Tracked` and `type Data`");
    }
    let mut block: syn::ItemImpl = syn::parse2(item)?;
    let associated = |name: &str| {
        block.items.iter().find_map(|item| match item {
            syn::ImplItem::Type(t) if t.ident == name => Some(t.ty.clone()),
            _ => None,
        })
    };
    let (tracked, data) = (associated("Tracked"), associated("Data"));
    let Some((_, trait_path, _)) = block.trait_.as_mut() else {
        return Err(syn::Error::new(
            block.self_ty.span(),
            "`#[declared_problem]` goes on `impl simhc::solver::DeclaredProblem for YourProblem { .. }`",
        ));
    };
    let anchor = trait_path.clone();
    for (found, name) in [(&tracked, "Tracked"), (&data, "Data")] {
        if found.is_none() {
            cx.error_spanned_by(
                &anchor,
                format!("missing `type {name} = ..;`: `#[declared_problem]` takes the sizes from `type Tracked` and `type Data`"),
            );
        }
    }
    let last = trait_path.segments.last_mut().expect("a parsed path has a segment");
    if !last.arguments.is_none() {
        cx.error_spanned_by(&last.arguments, "remove the sizes: `#[declared_problem]` fills them in from `type Tracked` and `type Data`");
    }
    cx.check()?;
    let (tracked, data) = (tracked.expect("checked"), data.expect("checked"));
    let size = |ty: &syn::Type, name: &str| {
        let ident = syn::Ident::new(name, ty.span());
        quote_spanned!(ty.span()=> { <#ty>::#ident })
    };
    let (nx, nf, np, nc) = (size(&tracked, "NX"), size(&tracked, "NF"), size(&tracked, "NP"), size(&tracked, "NC"));
    let nd = size(&data, "NP");
    last.arguments = syn::PathArguments::AngleBracketed(syn::parse2(quote!(<#nx, #nf, #np, #nc, #nd>))?);
    Ok(quote!(#block))
}
