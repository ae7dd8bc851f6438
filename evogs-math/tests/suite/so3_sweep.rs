//! Accuracy sweep: every SO(3) map in f64 against 50-digit references (mpmath; the data and
//! its generator are in `tests/data/so3_sweep/`) at angles 1e-12 … 1e-3, around each series
//! threshold, moderate angles, π − 1e-12 … π − 1e-3 and π. Requirement: relative error at
//! most 1e-14 everywhere (norm-wise for vectors and matrices; for the coefficient functions
//! that stay well-conditioned on [0, π]).

use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::so3_coeffs::{
    cos_half, jinv_coeff, one_minus_cos_over_sq, sinc, theta_minus_sin_over_cube,
};
use evogs_math::so3_jacobians::{
    left_jacobian, left_jacobian_inv, right_jacobian, right_jacobian_inv,
};
use evogs_math::{Mat3, Quat, Vec3};
use serde_json::Value;

const REL_TOL: f64 = 1e-14;

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}
fn m3(v: &Value) -> Mat3<f64> {
    let mut m = Mat3::zero();
    for i in 0..3 {
        for j in 0..3 {
            m.m[i][j] = f(&v[i][j]);
        }
    }
    m
}
fn rel_mat(got: Mat3<f64>, want: Mat3<f64>) -> f64 {
    (got - want).max_abs() / want.max_abs()
}
fn rel_vec(got: &[f64], want: &[f64]) -> f64 {
    let d = got
        .iter()
        .zip(want)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    d / want.iter().fold(0.0_f64, |m, b| m.max(b.abs()))
}

#[test]
fn every_map_is_accurate_to_1e14_relative_at_every_angle() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/so3_sweep/so3_sweep.json"
    );
    let data: Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("sweep data")).expect("JSON");
    let cases = data["cases"].as_array().expect("cases");
    assert!(cases.len() >= 90, "sweep has {} cases", cases.len());
    let mut worst: Vec<(&str, f64, f64)> = Vec::new();
    let mut record = |what: &'static str, err: f64, theta: f64| {
        assert!(
            err <= REL_TOL,
            "{what}: relative error {err:.3e} at θ = {theta:e}"
        );
        match worst.iter_mut().find(|w| w.0 == what) {
            Some(w) if err > w.1 => *w = (what, err, theta),
            Some(_) => {}
            None => worst.push((what, err, theta)),
        }
    };
    for c in cases {
        let phi = Vec3::new(f(&c["rotvec"][0]), f(&c["rotvec"][1]), f(&c["rotvec"][2]));
        let theta = f(&c["theta"]);
        let q_ref = Quat::new(
            f(&c["quat_wxyz"][0]),
            f(&c["quat_wxyz"][1]),
            f(&c["quat_wxyz"][2]),
            f(&c["quat_wxyz"][3]),
        );
        record(
            "exp_quat",
            rel_vec(&exp_quat(phi).to_array(), &q_ref.to_array()),
            theta,
        );
        // The vector part alone (it is tiny at small angles, so this is the strict test).
        record(
            "exp_quat vector part",
            rel_vec(&exp_quat(phi).vec().to_array(), &q_ref.vec().to_array()),
            theta,
        );
        record(
            "exp_matrix",
            rel_mat(exp_matrix(phi), m3(&c["matrix"])),
            theta,
        );
        record("Jl", rel_mat(left_jacobian(phi), m3(&c["Jl"])), theta);
        record("Jr", rel_mat(right_jacobian(phi), m3(&c["Jr"])), theta);
        record(
            "Jl_inv",
            rel_mat(left_jacobian_inv(phi), m3(&c["Jl_inv"])),
            theta,
        );
        record(
            "Jr_inv",
            rel_mat(right_jacobian_inv(phi), m3(&c["Jr_inv"])),
            theta,
        );
        // Logs of the (f64-rounded) reference exponentials return φ.
        let at_pi = (theta - core::f64::consts::PI).abs() < 1e-15;
        let sign_free = |l: Vec3<f64>| {
            let e = rel_vec(&l.to_array(), &phi.to_array());
            if at_pi {
                e.min(rel_vec(&(-l).to_array(), &phi.to_array()))
            } else {
                e
            }
        };
        record("log_quat", sign_free(log_quat(q_ref)), theta);
        record("log_matrix", sign_free(log_matrix(m3(&c["matrix"]))), theta);
        let t2 = phi.norm_squared();
        let co = &c["coeffs"];
        // sin θ/θ and cos(θ/2) vanish at π, where they are ill-conditioned in θ (an input
        // rounding of ε·π moves them by ~ε·π): they are held to 1e-15 absolute (their
        // products with K stay 1e-14 relative, see exp_quat/exp_matrix above).
        for (what, got, want) in [
            ("sinc", sinc(t2), f(&co["sinc"])),
            ("cos_half", cos_half(t2), f(&co["cos_half"])),
        ] {
            let err = (got - want).abs();
            assert!(
                err <= 1e-15,
                "{what}: absolute error {err:.3e} at θ = {theta:e}"
            );
        }
        for (what, got, want) in [
            ("A = (1-cos)/θ²", one_minus_cos_over_sq(t2), f(&co["A"])),
            ("B = (θ-sin)/θ³", theta_minus_sin_over_cube(t2), f(&co["B"])),
            ("D", jinv_coeff(t2), f(&co["D"])),
        ] {
            record(what, (got - want).abs() / want.abs(), theta);
        }
    }
    for (what, e, theta) in &worst {
        println!("so3 sweep: {what:22} worst rel err {e:.2e} (at θ = {theta:.3e})");
    }
}
