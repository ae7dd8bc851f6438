//! Every case of the SE(3) reference file (scipy `expm`, 50-digit mpmath sums
//! `Jl = Σ ad(ξ)ⁿ/(n+1)!`), at 1e-12 relative to max(1, |ref|) for every quantity the file
//! lists: the exponential (matrix, quaternion, translation), the four Jacobians, `Ad`, `ad`,
//! the inverse, a composition, the action on a point and the logarithm of the matrix.
//!
//! The same checks run on the accuracy sweep `tests/data/se3_sweep/se3_sweep.json` (same
//! schema, 60-digit mpmath, generator beside it): angles 1e-12 … 1e-2, each series threshold
//! at ±1e-9, π − 1e-2 … π − 1e-8, beyond π up to 5.5, and a large translation.

use evogs_math::se3::ad;
use evogs_math::se3_jacobians::{
    left_jacobian, left_jacobian_inv, right_jacobian, right_jacobian_inv,
};
use evogs_math::{Mat6, Se3, Vec3, Vec6};
use serde_json::Value;

const TOL: f64 = 1e-12;

fn load(file: &str) -> Value {
    let path = format!("{}/../tests/data/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {path}: {e}"));
    serde_json::from_str(&text).expect("valid JSON")
}

/// All numbers of a nested array, row-major.
fn flat(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(flat).collect(),
        n => vec![n.as_f64().expect("number")],
    }
}

fn vec6(v: &Value) -> Vec6<f64> {
    Vec6::from_slice(&flat(v))
}

fn mat4(v: &Value) -> [[f64; 4]; 4] {
    let f = flat(v);
    core::array::from_fn(|i| core::array::from_fn(|j| f[4 * i + j]))
}

fn m6(m: Mat6<f64>) -> Vec<f64> {
    m.m.as_flattened().to_vec()
}

/// Tracks the worst error per quantity (relative to max(1, |ref|)), printed at the end.
#[derive(Default)]
struct Worst(Vec<(&'static str, f64)>);

impl Worst {
    fn record(&mut self, what: &'static str, got: &[f64], want: &[f64], case: &str) {
        assert_eq!(got.len(), want.len(), "{what}: length");
        let err = got
            .iter()
            .zip(want)
            .map(|(a, r)| (a - r).abs() / r.abs().max(1.0))
            .fold(0.0, f64::max);
        assert!(err <= TOL, "{what} off by {err:.3e} in case {case}");
        match self.0.iter_mut().find(|(w, _)| *w == what) {
            Some((_, e)) => *e = e.max(err),
            None => self.0.push((what, err)),
        }
    }
}

/// Checks every case of a file in the oracle's se3 schema and prints the worst errors.
fn check_file(file: &str) {
    let data = load(file);
    assert_eq!(data["kind"], "se3", "file kind");
    let cases = data["cases"].as_array().expect("cases");
    assert!(!cases.is_empty(), "reference file has cases");
    let mut worst = Worst::default();
    let mut logs = 0;
    for c in cases {
        let kind = c["kind"].as_str().expect("kind");
        let xi = vec6(&c["xi"]);
        let t = Se3::exp(xi);
        worst.record("angle", &[xi.tail.norm()], &flat(&c["angle"]), kind);
        worst.record(
            "matrix",
            t.to_matrix().as_flattened(),
            &flat(&c["matrix"]),
            kind,
        );
        // The file stores the rotation with w ≥ 0; Exp does not canonicalise (|φ| > π).
        let q = if t.quat().w < 0.0 {
            -t.quat()
        } else {
            t.quat()
        };
        worst.record("quat_wxyz", &q.to_array(), &flat(&c["quat_wxyz"]), kind);
        worst.record(
            "translation",
            &t.translation().to_array(),
            &flat(&c["translation"]),
            kind,
        );
        for (what, m) in [
            ("Jl", left_jacobian(xi)),
            ("Jr", right_jacobian(xi)),
            ("Jl_inv", left_jacobian_inv(xi)),
            ("Jr_inv", right_jacobian_inv(xi)),
            ("Ad", t.adjoint()),
            ("ad", ad(xi)),
        ] {
            worst.record(what, &m6(m), &flat(&c[what]), kind);
        }
        worst.record(
            "inverse",
            t.inverse().to_matrix().as_flattened(),
            &flat(&c["inverse"]),
            kind,
        );
        let other = Se3::exp(vec6(&c["other_xi"]));
        worst.record(
            "compose_with_other",
            (t * other).to_matrix().as_flattened(),
            &flat(&c["compose_with_other"]),
            kind,
        );
        let p = Vec3::from_slice(&flat(&c["point"]));
        worst.record(
            "act_on_point",
            &t.act(p).to_array(),
            &flat(&c["act_on_point"]),
            kind,
        );
        if let Some(want) = c.get("log_of_matrix") {
            let got = Se3::from_matrix(&mat4(&c["matrix"])).log();
            worst.record("log_of_matrix", &got.to_array(), &flat(want), kind);
            logs += 1;
        }
    }
    assert!(logs > 0, "some cases have a logarithm");
    for (what, e) in &worst.0 {
        println!("{file}: {what:20} worst error / max(1, |ref|) {e:.3e}");
    }
}

#[test]
fn every_case_of_the_shared_file_matches() {
    check_file("oracle/se3_shared_cases.json");
}

#[test]
fn every_case_of_the_accuracy_sweep_matches() {
    check_file("se3_sweep/se3_sweep.json");
}
