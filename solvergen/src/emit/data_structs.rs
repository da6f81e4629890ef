//! The plain-data structs of a declaration (`Unknowns`, `Row`, `Globals`) with their packing
//! into flat scalars, and the `simhc::FieldLayout` tables that describe the same packing at run
//! time. Both walk the fields in declaration order, so they agree by construction.

use crate::decl::{Field, Shape};
use proc_macro2::{Ident, TokenStream};
use quote::quote;

use super::n;

/// Plain-data struct of a declaration section, with packing into a flat slice.
pub(super) fn data_struct(name: &Ident, doc: &str, fields: &[Field]) -> TokenStream {
    let decls = fields.iter().map(|f| {
        let ident = &f.ident;
        let ty = f.shape.rust_type();
        let attrs = &f.attrs;
        quote!(#(#attrs)* pub #ident: #ty,)
    });
    let len_value: usize = fields.iter().map(|f| f.shape.scalar_count()).sum();
    let len = n(len_value);
    let mut writes = Vec::new();
    let mut reads = Vec::new();
    let mut next = 0usize;
    let mut k = || {
        next += 1;
        n(next - 1)
    };
    for f in fields {
        let ident = &f.ident;
        match f.shape {
            Shape::Scalar => {
                let k = k();
                writes.push(quote!(out[#k] = self.#ident;));
                reads.push(quote!(v.#ident = src[#k];));
            }
            Shape::Vector(_) | Shape::Quat => {
                for i in (0..f.shape.scalar_count()).map(n) {
                    let k = k();
                    writes.push(quote!(out[#k] = self.#ident[#i];));
                    reads.push(quote!(v.#ident[#i] = src[#k];));
                }
            }
            Shape::Matrix(r, c) => {
                for i in (0..r).map(n) {
                    for j in (0..c).map(n) {
                        let k = k();
                        writes.push(quote!(out[#k] = self.#ident[#i][#j];));
                        reads.push(quote!(v.#ident[#i][#j] = src[#k];));
                    }
                }
            }
            Shape::Sym(size) => {
                for i in 0..size {
                    for j in i..size {
                        let k = k();
                        let diagonal = i == j;
                        let (i, j) = (n(i), n(j));
                        writes.push(quote!(out[#k] = self.#ident[#i][#j];));
                        if diagonal {
                            reads.push(quote!(v.#ident[#i][#j] = src[#k];));
                        } else {
                            reads.push(quote!(v.#ident[#i][#j] = src[#k]; v.#ident[#j][#i] = src[#k];));
                        }
                    }
                }
            }
        }
    }
    let sym_note = if fields.iter().any(|f| matches!(f.shape, Shape::Sym(_))) {
        " Symmetric matrices contribute their upper triangle, row by row."
    } else {
        ""
    };
    let write_doc = format!(" Writes the {len_value} scalars in parameter order (declaration order, vectors by component).{sym_note}");
    quote! {
        #[doc = #doc]
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        pub struct #name { #(#decls)* }
        impl #name {
            /// Number of scalars.
            pub const LEN: usize = #len;
            #[doc = #write_doc]
            pub fn write_to(&self, out: &mut [f64; #len]) { #(#writes)* }
            /// Reads the scalars written by `write_to`.
            pub fn read_from(src: &[f64; #len]) -> Self {
                let mut v = Self::default();
                #(#reads)*
                v
            }
        }
    }
}

/// `::simhc::FieldLayout` literals of `fields`, offsets counted from the first.
pub(super) fn field_layouts(fields: &[Field]) -> Vec<TokenStream> {
    let mut offset = 0usize;
    fields
        .iter()
        .map(|f| {
            let name = f.ident.to_string();
            let kind = match f.shape {
                Shape::Scalar => quote!(::simhc::FieldKind::Scalar),
                Shape::Vector(k) => {
                    let k = n(k);
                    quote!(::simhc::FieldKind::Vector(#k))
                }
                Shape::Quat => quote!(::simhc::FieldKind::Quat),
                Shape::Matrix(r, c) => {
                    let (r, c) = (n(r), n(c));
                    quote!(::simhc::FieldKind::Matrix(#r, #c))
                }
                Shape::Sym(k) => {
                    let k = n(k);
                    quote!(::simhc::FieldKind::Sym(#k))
                }
            };
            let at = n(offset);
            offset += f.shape.scalar_count();
            quote!(::simhc::FieldLayout { name: #name, kind: #kind, offset: #at })
        })
        .collect()
}
