//! Shared helpers of the evogs-splat integration tests: oracle JSON loading, scene
//! construction and error bookkeeping.
#![allow(dead_code, reason = "each test binary uses a subset of the helpers")]

use evogs_math::activation::logit;
use evogs_math::activation::sigmoid;
use evogs_math::{Quat, Vec3};
use evogs_splat::{PinholeCamera, RenderGrad, Splats};
use serde_json::Value;

/// Loads an oracle file from `tests/data/oracle/`.
pub(crate) fn load(name: &str) -> Value {
    let path = format!("{}/../tests/data/oracle/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("read {path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("parse {path}: {e}"))
}

/// A JSON number.
pub(crate) fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// A JSON integer as usize.
pub(crate) fn int(v: &Value) -> usize {
    usize::try_from(v.as_u64().unwrap_or_else(|| panic!("not an integer: {v}"))).expect("fits")
}

/// All numbers of a nested array, row-major.
pub(crate) fn flat(v: &Value) -> Vec<f64> {
    let mut out = Vec::new();
    fn rec(v: &Value, out: &mut Vec<f64>) {
        match v {
            Value::Array(a) => a.iter().for_each(|x| rec(x, out)),
            Value::Bool(b) => out.push(if *b { 1.0 } else { 0.0 }),
            _ => out.push(num(v)),
        }
    }
    rec(v, &mut out);
    out
}

/// All booleans of a nested array, row-major.
pub(crate) fn bools(v: &Value) -> Vec<bool> {
    flat(v).iter().map(|&b| b > 0.5).collect()
}

/// A 3-vector from a JSON array.
pub(crate) fn vec3(v: &Value) -> Vec3<f64> {
    Vec3::from_slice(&flat(v))
}

/// A 4×4 matrix from a JSON array.
pub(crate) fn mat4(v: &Value) -> [[f64; 4]; 4] {
    let f = flat(v);
    std::array::from_fn(|i| std::array::from_fn(|j| f[4 * i + j]))
}

/// A 3×3 matrix from a JSON array.
pub(crate) fn mat3(v: &Value) -> [[f64; 3]; 3] {
    let f = flat(v);
    std::array::from_fn(|i| std::array::from_fn(|j| f[3 * i + j]))
}

/// The camera of an oracle case (`inputs.viewmat`, `K`, size, near, far).
pub(crate) fn camera(inputs: &Value) -> PinholeCamera<f64> {
    PinholeCamera::from_viewmat(
        mat4(&inputs["viewmat"]),
        mat3(&inputs["K"]),
        int(&inputs["width"]),
        int(&inputs["height"]),
        num(&inputs["near_plane"]),
        num(&inputs["far_plane"]),
    )
    .expect("oracle camera")
}

/// The Gaussians of an oracle case, converted to the raw parameterisation (log-scales,
/// opacity logits). SH coefficients are read if present (else a zero DC term).
pub(crate) fn splats(inputs: &Value) -> Splats<f64> {
    let means = inputs["means"].as_array().expect("means");
    let degree = inputs.get("sh_degree").map_or(0, int);
    let k = (degree + 1) * (degree + 1);
    let mut s = Splats::new(degree);
    for i in 0..means.len() {
        let sc = vec3(&inputs["scales"][i]);
        let q = flat(&inputs["quats"][i]);
        let o = num(&inputs["opacities"][i]);
        let sh: Vec<[f64; 3]> = match inputs.get("sh_coeffs") {
            Some(c) => (0..k)
                .map(|j| {
                    let t = flat(&c[i][j]);
                    [t[0], t[1], t[2]]
                })
                .collect(),
            None => vec![[0.0; 3]; k],
        };
        s.push(
            vec3(&means[i]),
            sc.map(f64::ln),
            Quat::from_slice(&q),
            logit(o),
            &sh,
        );
    }
    s
}

/// Error statistics of one quantity against a reference, with the rule
/// `|a − r| ≤ tol·max(floor, |r|)`.
#[derive(Debug)]
pub(crate) struct Cmp {
    pub(crate) name: String,
    pub(crate) tol: f64,
    pub(crate) floor: f64,
    pub(crate) n: usize,
    pub(crate) max_abs: f64,
    pub(crate) max_rel: f64,
    pub(crate) worst_ratio: f64,
    pub(crate) worst_index: usize,
}

impl Cmp {
    /// Compares `a` with the reference `r`.
    pub(crate) fn new(name: &str, a: &[f64], r: &[f64], tol: f64, floor: f64) -> Self {
        assert_eq!(a.len(), r.len(), "length of {name}");
        let mut c = Self {
            name: name.to_string(),
            tol,
            floor,
            n: a.len(),
            max_abs: 0.0,
            max_rel: 0.0,
            worst_ratio: 0.0,
            worst_index: 0,
        };
        for (i, (&x, &y)) in a.iter().zip(r).enumerate() {
            let err = (x - y).abs();
            let ratio = if err.is_nan() {
                f64::INFINITY
            } else {
                err / (tol * y.abs().max(floor))
            };
            c.max_abs = c.max_abs.max(err);
            if y != 0.0 {
                c.max_rel = c.max_rel.max(err / y.abs());
            }
            if ratio > c.worst_ratio || (i == 0 && ratio.is_infinite()) {
                c.worst_ratio = ratio;
                c.worst_index = i;
            }
        }
        c
    }

    /// Prints one line of statistics.
    pub(crate) fn print(&self) {
        println!(
            "  {:<44} n={:<5} max_abs={:.3e} max_rel={:.3e} ratio={:.3} (tol {:.0e}·max({}, |ref|))",
            self.name, self.n, self.max_abs, self.max_rel, self.worst_ratio, self.tol, self.floor
        );
    }

    /// Prints and asserts `ratio ≤ 1`.
    pub(crate) fn check(&self) {
        self.print();
        assert!(
            self.worst_ratio <= 1.0,
            "{} out of tolerance: worst index {}, ratio {}",
            self.name,
            self.worst_index,
            self.worst_ratio
        );
    }
}

/// The camera with its view matrix perturbed on the left, `V' = Exp(ξ^) V`,
/// ξ = (ρ, φ): `R' = Exp(φ) R`, `t' = Exp(φ) t + J_l(φ) ρ`.
pub(crate) fn perturb_left<T: evogs_math::Real>(
    cam: &PinholeCamera<T>,
    xi: &[T],
) -> PinholeCamera<T> {
    use evogs_math::so3::exp_matrix;
    use evogs_math::so3_jacobians::left_jacobian;
    let rho = Vec3::from_slice(xi);
    let phi = Vec3::from_slice(&xi[3..]);
    let e = exp_matrix(phi);
    let mut c = *cam;
    c.rotation = e.mul_mat(cam.rotation);
    c.translation = e.mul_vec(cam.translation) + left_jacobian(phi).mul_vec(rho);
    c
}

/// The camera with its rotation and translation replaced by 12 numbers (R row-major, t).
pub(crate) fn with_pose<T: evogs_math::Real>(cam: &PinholeCamera<T>, x: &[T]) -> PinholeCamera<T> {
    let mut c = *cam;
    c.rotation = evogs_math::Mat3::from_flat(std::array::from_fn(|k| x[k]));
    c.translation = Vec3::from_slice(&x[9..]);
    c
}

/// The 12 pose numbers (R row-major, t) of a camera.
pub(crate) fn pose12<T: evogs_math::Real>(cam: &PinholeCamera<T>) -> Vec<T> {
    let mut v = cam.rotation.to_flat().to_vec();
    v.extend(cam.translation.to_array());
    v
}

/// A test camera looking at the origin region, with a principal point off the centre.
pub(crate) fn test_camera(width: usize, height: usize) -> PinholeCamera<f64> {
    let mut cam = PinholeCamera::look_at(
        Vec3::new(0.4, -0.3, 4.5),
        Vec3::new(0.1, 0.05, 0.0),
        Vec3::new(0.05, 1.0, 0.0),
        0.9,
        width,
        height,
    )
    .expect("test camera");
    cam.cx += 1.3;
    cam.cy -= 0.7;
    cam.fy *= 1.05;
    cam
}

/// Compares the gradients of a full render (`g`, for `splats` seen by `cam`) with an oracle
/// gradient block (`params` in the oracle's linear scales and activated opacities, the view
/// matrix, the se(3) pose and the intermediate `raster_inputs`), each to `tol` relative to
/// `max(1, |ref|)`.
pub(crate) fn check_render_grads(
    label: &str,
    splats: &Splats<f64>,
    cam: &PinholeCamera<f64>,
    g: &RenderGrad<f64>,
    reference: &Value,
    tol: f64,
) {
    let s = splats;
    let chk = |name: &str, mine: &[f64], key: &Value| {
        Cmp::new(&format!("{label}.{name}"), mine, &flat(key), tol, 1.0).check();
    };
    let p = &reference["params"];
    let gm: Vec<f64> = g.splats.means.iter().flat_map(|v| v.to_array()).collect();
    chk("params.means", &gm, &p["means"]);
    let gq: Vec<f64> = g.splats.quats.iter().flat_map(|q| q.to_array()).collect();
    chk("params.quats", &gq, &p["quats"]);
    // ŝ = ln s: d/ds = (d/dŝ)/s.
    let gs: Vec<f64> = (0..s.len())
        .flat_map(|i| {
            let (d, ls) = (g.splats.log_scales[i], s.log_scales[i]);
            [d.x / ls.x.exp(), d.y / ls.y.exp(), d.z / ls.z.exp()]
        })
        .collect();
    chk("params.scales", &gs, &p["scales"]);
    // ô = logit(o): d/do = (d/dô)/(o(1 − o)).
    let go: Vec<f64> = (0..s.len())
        .map(|i| {
            let o = sigmoid(s.opacity_logits[i]);
            g.splats.opacity_logits[i] / (o * (1.0 - o))
        })
        .collect();
    chk("params.opacities", &go, &p["opacities"]);
    chk("params.sh_coeffs", &g.splats.sh.concat(), &p["sh_coeffs"]);
    chk(
        "params.viewmat",
        &g.camera.to_viewmat().concat(),
        &p["viewmat"],
    );
    chk(
        "params.pose_left_se3",
        &g.camera.to_pose_left_se3(cam),
        &p["pose_left_se3"],
    );
    let r = &reference["raster_inputs"];
    let m2: Vec<f64> = g.raster.means2d.iter().flat_map(|m| m.to_array()).collect();
    chk("raster_inputs.means2d", &m2, &r["means2d"]);
    chk(
        "raster_inputs.conics",
        &g.raster.conics.concat(),
        &r["conics"],
    );
    chk(
        "raster_inputs.colors",
        &g.raster.colors.concat(),
        &r["colors"],
    );
    chk(
        "raster_inputs.opacities_effective",
        &g.raster.opacities,
        &r["opacities_effective"],
    );
}
