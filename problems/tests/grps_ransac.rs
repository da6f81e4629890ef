//! GRPS inside the library solver's robust estimator ([`simhc::solver::Solver::estimate`] of
//! the 7-point solver, up to 4 validated roots per sample): the pose of a seeded
//! 200-correspondence scene with 30 % mismatches and 2 px noise is recovered; bad input is
//! named. Seeds fixed and printed; no timing is asserted.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::ransac::RansacOptions;
use simhc::solver::EstimateError;
use simhc_problems::grps::declared::{GrpsSolvers, RANSAC_NOISE_PX};
use simhc_problems::grps::pose::GrpsPose;
use simhc_problems::grps::row_numbers;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::metrics::{rotation_error_deg, scale_error_pct, translation_error_pct};

#[test]
fn ransac_recovers_the_pose_with_30_percent_outliers() {
    let solvers = GrpsSolvers::new(RANSAC_NOISE_PX).expect("weights");
    let mut recovered = 0;
    for seed in [11u64, 12, 13] {
        println!("seed {seed}");
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let config = GrpsSceneConfig { points: 200, cameras_per_view: 5, noise_px: 2.0 * std::f64::consts::SQRT_2, focal_px: 800.0 };
        let mut scene = config.sample(&mut rng).expect("valid config");
        let original = scene.correspondences.clone();
        let mut outlier = [false; 200];
        for i in 0..60 {
            let other = (i + 1 + rng.random_range(0..199)) % 200;
            scene.correspondences[i].fp = original[other].fp;
            scene.correspondences[i].vp = original[other].vp;
            outlier[i] = true;
        }
        let options = RansacOptions { seed, local_optimization: true, ..RansacOptions::default() };
        let rows: Vec<f64> = row_numbers(&scene.correspondences).collect();
        let (x, r) = solvers.seven.estimate((&rows, &[]), &options).expect("a model");
        let model = GrpsPose::from_unknowns(&x).expect("a pose");
        let er = rotation_error_deg(&model.rotation, &scene.rotation);
        let et = translation_error_pct(&model.translation, &scene.translation);
        let es = scale_error_pct(model.scale, scene.scale);
        let true_inliers = r.inliers.iter().filter(|&&i| !outlier[i]).count();
        println!(
            "  E_R {er:.3} deg, E_t {et:.2} %, E_s {es:.2} %, {} inliers ({true_inliers} true), {} iterations",
            r.inliers.len(),
            r.iterations
        );
        if er < 2.0 {
            assert!(true_inliers >= 120, "most of the 140 inliers are found");
            recovered += 1;
        }
    }
    assert!(recovered >= 3, "{recovered}/3 recovered");
}

#[test]
fn the_estimator_names_a_bad_correspondence_and_needs_a_sample() {
    let solvers = GrpsSolvers::new(RANSAC_NOISE_PX).expect("weights");
    let mut scene = GrpsSceneConfig::default().sample_seeded(3).expect("valid config");
    let options = RansacOptions::poselib(0.01);
    let rows: Vec<f64> = row_numbers(&scene.correspondences[..7]).collect();
    let err = solvers.eight.estimate((&rows, &[]), &options).unwrap_err();
    assert_eq!(err, EstimateError::TooFew { rows: 7, needed: 8 });
    scene.correspondences[5].fp.z = f64::NAN;
    let rows: Vec<f64> = row_numbers(&scene.correspondences).collect();
    match solvers.seven.estimate((&rows, &[]), &options).unwrap_err() {
        EstimateError::NonFinite(at) => {
            assert_eq!(at.row, Some(5));
            assert!(at.to_string().contains("fp"), "{at}");
        }
        other => panic!("a NaN in correspondence 5: {other:?}"),
    }
}
