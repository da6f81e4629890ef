//! Cost of one generated residual+Jacobian evaluation for the built-in systems
//! (`cargo bench -p simhc-tests --bench evaluation`).

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{SMatrix, SVector};
use simhc::Problem;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::{grps, metrics, upnp};
use std::hint::black_box;

fn evaluation(c: &mut Criterion) {
    let seed = 1;
    println!("seed {seed}");
    let scene = GrpsSceneConfig::default().sample_seeded(seed).expect("valid config");
    let x = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
    let p = grps::Grps8::params(&grps::rows_of::<8>(&scene.correspondences).expect("8 rows"));
    let mut f = SVector::<f64, 9>::zeros();
    let mut j = SMatrix::<f64, 9, 8>::zeros();
    c.bench_function("grps8 residual_jacobian f64", |b| {
        b.iter(|| grps::Grps8::residual_jacobian(black_box(&x), black_box(&p), &mut f, &mut j))
    });
    c.bench_function("grps8 residual f64", |b| b.iter(|| grps::Grps8::residual(black_box(&x), black_box(&p), &mut f)));

    let scene = UpnpSceneConfig::default().sample_seeded(seed).expect("valid config");
    let m = simhc_problems::upnp::geometry::upnp_cost_matrix(&scene.correspondences).expect("scene");
    let q = SVector::<f64, 4>::from(metrics::quat_from_rotation(&scene.rotation));
    let p = upnp::params_of(&m);
    let mut f = SVector::<f64, 5>::zeros();
    let mut j = SMatrix::<f64, 5, 4>::zeros();
    c.bench_function("upnp residual_jacobian f64", |b| {
        b.iter(|| upnp::Upnp::residual_jacobian(black_box(&q), black_box(&p), &mut f, &mut j))
    });
}

criterion_group!(benches, evaluation);
criterion_main!(benches);
