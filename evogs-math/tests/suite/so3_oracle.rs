//! Every case of the SO(3) reference file (scipy `Rotation`, mpmath at 50 digits, torch
//! autograd of `matrix_exp`), at 1e-13 absolute, plus the coefficient functions at 1e-14
//! relative against the 50-digit values.

use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::so3_coeffs::{jinv_coeff, one_minus_cos_over_sq, theta_minus_sin_over_cube};
use evogs_math::so3_jacobians::{
    left_jacobian, left_jacobian_inv, right_jacobian, right_jacobian_inv,
};
use evogs_math::update::{exp_update_left, exp_update_right};
use evogs_math::{Mat3, Quat, Vec3};
use serde_json::Value;

const TOL: f64 = 1e-13;

fn load() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/oracle/so3_shared_cases.json"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {path}: {e}"));
    serde_json::from_str(&text).expect("valid JSON")
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}
fn v3(v: &Value) -> Vec3<f64> {
    Vec3::new(f(&v[0]), f(&v[1]), f(&v[2]))
}
fn q4(v: &Value) -> Quat<f64> {
    Quat::new(f(&v[0]), f(&v[1]), f(&v[2]), f(&v[3]))
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

/// Tracks the worst absolute error per quantity, printed at the end (`--nocapture`).
#[derive(Default)]
struct Worst(Vec<(&'static str, f64)>);

impl Worst {
    fn record(&mut self, what: &'static str, err: f64, case: &str) {
        assert!(err <= TOL, "{what} off by {err:.3e} in case {case}");
        match self.0.iter_mut().find(|(w, _)| *w == what) {
            Some((_, e)) => *e = e.max(err),
            None => self.0.push((what, err)),
        }
    }
}

#[test]
fn rotvec_cases_match_the_reference() {
    let data = load();
    let mut worst = Worst::default();
    let cases = data["rotvec_cases"].as_array().expect("cases");
    assert!(!cases.is_empty(), "reference file has cases");
    for c in cases {
        let kind = c["kind"].as_str().expect("kind");
        let phi = v3(&c["rotvec"]);
        worst.record(
            "exp quaternion",
            (exp_quat(phi) - q4(&c["quat_wxyz"]))
                .to_array()
                .iter()
                .fold(0.0, |a, b| a.max(b.abs())),
            kind,
        );
        worst.record(
            "exp matrix",
            (exp_matrix(phi) - m3(&c["matrix"])).max_abs(),
            kind,
        );
        let ambiguous = c["log_sign_ambiguous"].as_bool().expect("flag");
        let either = |got: Vec3<f64>, want: Vec3<f64>| {
            let e = (got - want)
                .to_array()
                .iter()
                .fold(0.0_f64, |a, b| a.max(b.abs()));
            let e_neg = (got + want)
                .to_array()
                .iter()
                .fold(0.0_f64, |a, b| a.max(b.abs()));
            if ambiguous { e.min(e_neg) } else { e }
        };
        worst.record(
            "log of quaternion",
            either(log_quat(q4(&c["quat_wxyz"])), v3(&c["log_of_quat"])),
            kind,
        );
        worst.record(
            "log of matrix",
            either(log_matrix(m3(&c["matrix"])), v3(&c["log_of_matrix"])),
            kind,
        );
        worst.record("Jl", (left_jacobian(phi) - m3(&c["Jl"])).max_abs(), kind);
        worst.record("Jr", (right_jacobian(phi) - m3(&c["Jr"])).max_abs(), kind);
        worst.record(
            "Jl_inv",
            (left_jacobian_inv(phi) - m3(&c["Jl_inv"])).max_abs(),
            kind,
        );
        worst.record(
            "Jr_inv",
            (right_jacobian_inv(phi) - m3(&c["Jr_inv"])).max_abs(),
            kind,
        );
        // The coefficient functions, relative to the 50-digit values.
        let t2 = phi.norm_squared();
        if t2 > 0.0 {
            let co = &c["jacobian_coeffs"];
            for (name, got, want) in [
                ("A", one_minus_cos_over_sq(t2), f(&co["A"])),
                ("B", theta_minus_sin_over_cube(t2), f(&co["B"])),
                ("D", jinv_coeff(t2), f(&co["D"])),
            ] {
                let rel = (got - want).abs() / want.abs();
                assert!(
                    rel <= 1e-14,
                    "coefficient {name} relative error {rel:.2e} at θ² = {t2:e} ({kind})"
                );
            }
        }
    }
    for (what, e) in &worst.0 {
        println!("so3 oracle: {what:20} worst abs err {e:.3e}");
    }
}

#[test]
fn quaternion_updates_match_the_reference() {
    let data = load();
    let mut worst = Worst::default();
    for c in data["quat_update_cases"].as_array().expect("cases") {
        let (q, w, dt) = (q4(&c["q"]), v3(&c["omega"]), f(&c["dt"]));
        let max_q = |a: Quat<f64>, b: Quat<f64>| {
            (a - b)
                .to_array()
                .iter()
                .fold(0.0_f64, |m, x| m.max(x.abs()))
        };
        worst.record(
            "dq_exp",
            max_q(exp_quat(w * dt), q4(&c["dq_exp"])),
            "update",
        );
        let right = exp_update_right(q, w, dt);
        let left = exp_update_left(q, w, dt);
        worst.record("q_right", max_q(right, q4(&c["q_right"])), "update");
        worst.record("q_left", max_q(left, q4(&c["q_left"])), "update");
        worst.record(
            "R_right",
            (right.to_rotation_matrix() - m3(&c["R_right"])).max_abs(),
            "update",
        );
        worst.record(
            "R_left",
            (left.to_rotation_matrix() - m3(&c["R_left"])).max_abs(),
            "update",
        );
    }
    for (what, e) in &worst.0 {
        println!("so3 oracle: {what:20} worst abs err {e:.3e}");
    }
}
