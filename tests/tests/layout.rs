//! The emitted layout metadata agrees with the generated packing: each field's offset and
//! length select exactly the values `params` and `unknowns_vector` wrote.

use simhc::{FieldKind, ProblemLayout};

#[simhc::simhc_problem]
mod mixed {
    pub struct Unknowns {
        q: Quat,
        t: Vec3,
        s: Scalar,
    }
    pub struct Row {
        f: Vec3,
        w: Vector<2>,
        h: Scalar,
    }
    pub struct Globals {
        m: Sym<3>,
        c: Scalar,
    }
    pub const ROWS: [usize; 1] = [3];
    pub fn row_equations() -> Vec3 {
        f.cross(s * (rotation(q) * t)) + c * f + (w[0] * h - w[1]) * t
    }
    pub fn global_equations() -> [Scalar; 2] {
        [q.dot(q) - 1, t.dot(m * t) - 1]
    }
}

#[test]
fn layout_offsets_select_the_packed_values() {
    let layout = mixed::Mixed3::LAYOUT;
    assert_eq!((layout.rows, layout.per_row, layout.unknown_len(), layout.param_len()), (3, 6, 8, 3 * 6 + 7));
    assert_eq!(
        layout.unknowns.iter().map(|f| (f.name, f.kind)).collect::<Vec<_>>(),
        [("q", FieldKind::Quat), ("t", FieldKind::Vector(3)), ("s", FieldKind::Scalar)]
    );

    let rows: [mixed::Row; 3] = std::array::from_fn(|r| {
        let r = r as f64;
        mixed::Row { f: [r, r + 0.1, r + 0.2], w: [10.0 + r, 11.0], h: 12.0 + r }
    });
    let globals = mixed::Globals { m: [[1.0, 2.0, 3.0], [2.0, 4.0, 5.0], [3.0, 5.0, 6.0]], c: 7.5 };
    let p = mixed::Mixed3::params(&rows, &globals);
    assert_eq!(p.len(), layout.param_len());
    for (r, row) in rows.iter().enumerate() {
        let block = layout.row_params(p.as_slice(), r).expect("row block");
        let field = |name: &str| {
            let f = layout.row.iter().find(|f| f.name == name).expect("field");
            &block[f.offset..f.offset + f.kind.len()]
        };
        assert_eq!(field("f"), row.f);
        assert_eq!(field("w"), row.w);
        assert_eq!(field("h"), [row.h]);
    }
    assert!(layout.row_params(p.as_slice(), 3).is_none());
    let g = layout.global_params(p.as_slice()).expect("globals");
    let m = layout.globals.iter().find(|f| f.name == "m").expect("m");
    assert_eq!(m.kind, FieldKind::Sym(3));
    assert_eq!(&g[m.offset..m.offset + 6], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], "upper triangle, row-major");
    let c = layout.globals.iter().find(|f| f.name == "c").expect("c");
    assert_eq!(g[c.offset], 7.5);

    let u = mixed::Unknowns { q: [0.5, 0.5, -0.5, 0.5], t: [1.0, 2.0, 3.0], s: 4.0 };
    let x = mixed::Mixed3::unknowns_vector(&u);
    let t = layout.unknowns.iter().find(|f| f.name == "t").expect("t");
    assert_eq!(&x.as_slice()[t.offset..t.offset + 3], u.t);
}
