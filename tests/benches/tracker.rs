//! Time per tracked path on the built-in systems, adaptive (single-path preset) against the
//! paper's fixed schedule on the same paths (`cargo bench -p simhc-tests --bench tracker`).
//! Success rates and step counts of the same comparison: `simhc bench tracker`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::SVector;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::homotopy::CoefficientLine;
use simhc::tracker::{track, TrackerOptions};
use simhc::OnlineSimulator;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::metrics::{perturb_scale, perturb_translation, quat_from_rotation, random_rotation_perturbation};
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::{grps, upnp};
use std::hint::black_box;

const PATHS: usize = 32;

type GrpsLine = CoefficientLine<grps::Grps8, f64, 96, 304>;
type UpnpLine = CoefficientLine<upnp::Upnp, f64, 66, 35>;

fn grps_paths(seed: u64) -> Vec<(GrpsLine, SVector<f64, 8>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < PATHS {
        let Ok(scene) = GrpsSceneConfig::default().sample(&mut rng) else { continue };
        let r0 = random_rotation_perturbation(&scene.rotation, 20.0, &mut rng);
        let x0 = grps::unknowns_of(&r0, &perturb_translation(&scene.translation, 0.1, &mut rng), perturb_scale(scene.scale, 0.1, &mut rng));
        let Some(rows) = grps::rows_of::<8>(&scene.correspondences) else { continue };
        let p1 = grps::Grps8::params(&rows);
        let Ok(p0) = simhc::MinNormSimulator::<grps::Grps8>::new().simulate(&x0, &p1) else { continue };
        out.push((GrpsLine::new::<8, 9>(&p0, &p1), x0));
    }
    out
}

fn upnp_paths(seed: u64) -> Vec<(UpnpLine, SVector<f64, 4>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < PATHS {
        let Ok(scene) = UpnpSceneConfig::default().sample(&mut rng) else { continue };
        let q0 = quat_from_rotation(&random_rotation_perturbation(&scene.rotation, 20.0, &mut rng));
        let Ok(target) = upnp_system(&scene.correspondences) else { continue };
        let Ok(m0) = simhc_problems::upnp::simulator::simulate(&target, &scene.correspondences, q0) else { continue };
        out.push((UpnpLine::new::<4, 5>(&upnp::params_of(&m0), &upnp::params_of(&target.m)), SVector::from(q0)));
    }
    out
}

fn paths(c: &mut Criterion) {
    let seed = 1;
    println!("seed {seed}; {PATHS} paths per benchmark, starts 20 deg off; times are per {PATHS} paths");
    let grps = grps_paths(seed);
    let upnp = upnp_paths(seed);
    for (name, options) in [("adaptive+drag", TrackerOptions::single_path()), ("paper dt=0.05", TrackerOptions::paper(0.05))] {
        c.bench_function(&format!("grps8 {PATHS} paths {name}"), |b| {
            b.iter(|| {
                for (h, x0) in &grps {
                    let _ = black_box(track(h, x0, &options));
                }
            })
        });
    }
    for (name, options) in [("adaptive+drag", TrackerOptions::single_path()), ("paper dt=0.02", TrackerOptions::paper(0.02))] {
        c.bench_function(&format!("upnp {PATHS} paths {name}"), |b| {
            b.iter(|| {
                for (h, x0) in &upnp {
                    let _ = black_box(track(h, x0, &options));
                }
            })
        });
    }
}

criterion_group!(benches, paths);
criterion_main!(benches);
