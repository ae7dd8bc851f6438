//! evogs-math VJPs: covariance, SH evaluation, exp map, `Jl⁻¹·ω`, exp updates, activations.
//! Points include the small-angle and near-π regimes of the SO(3) maps.

use super::{GradRow, Kernel, check_kernel, uniform};
use evogs_math::activation::{
    exp3, exp3_vjp, normalize_quat, normalize_quat_vjp, normalize_vec3, normalize_vec3_vjp,
    sigmoid, sigmoid_vjp,
};
use evogs_math::covariance::{covariance, covariance_vjp};
use evogs_math::quat::{rotation_from_raw, rotation_from_raw_vjp};
use evogs_math::rng::SplitMix64;
use evogs_math::sh::{sh_eval, sh_eval_vjp};
use evogs_math::so3::exp_quat;
use evogs_math::so3_jacobians::{exp_quat_vjp, jl_inv_mul, jl_inv_mul_vjp};
use evogs_math::update::{
    exp_update_left, exp_update_left_vjp, exp_update_right, exp_update_right_vjp,
};
use evogs_math::{Mat3, Quat, Real, Sym3, Vec3};

fn v3<T: Real>(x: &[T]) -> Vec3<T> {
    Vec3::from_slice(x)
}

fn q4<T: Real>(x: &[T]) -> Quat<T> {
    Quat::from_slice(x)
}

struct Covariance;

impl Kernel for Covariance {
    fn n_in(&self) -> usize {
        7
    }
    fn n_out(&self) -> usize {
        6
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let s = covariance(v3(x), q4(&x[3..]));
        out.copy_from_slice(&[s.xx, s.xy, s.xz, s.yy, s.yz, s.zz]);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let g = Sym3::new(w[0], w[1], w[2], w[3], w[4], w[5]);
        let (dl, dq) = covariance_vjp(v3(x), q4(&x[3..]), g);
        d[..3].copy_from_slice(&dl.to_array());
        d[3..].copy_from_slice(&dq.to_array());
    }
}

/// SH of degree 3: inputs 16 RGB coefficients and an (unnormalised) direction.
struct Sh;

impl Kernel for Sh {
    fn n_in(&self) -> usize {
        51
    }
    fn n_out(&self) -> usize {
        3
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let c: Vec<[T; 3]> = x[..48].chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
        out.copy_from_slice(&sh_eval(3, &c, v3(&x[48..])));
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let c: Vec<[f64; 3]> = x[..48].chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mut dc = vec![[0.0; 3]; 16];
        let dd = sh_eval_vjp(3, &c, v3(&x[48..]), [w[0], w[1], w[2]], &mut dc);
        d[..48].copy_from_slice(&dc.concat());
        d[48..].copy_from_slice(&dd.to_array());
    }
}

/// `exp_quat(φ)`.
struct ExpMap;

impl Kernel for ExpMap {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        4
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        exp_quat(v3(x)).write_to(out);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        d.copy_from_slice(&exp_quat_vjp(v3(x), q4(w)).to_array());
    }
}

/// `Jl⁻¹(Ω)·ω`.
struct JlInv;

impl Kernel for JlInv {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        3
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        jl_inv_mul(v3(x), v3(&x[3..])).write_to(out);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let (a, b) = jl_inv_mul_vjp(v3(x), v3(&x[3..]), v3(w));
        d[..3].copy_from_slice(&a.to_array());
        d[3..].copy_from_slice(&b.to_array());
    }
}

/// `Exp(ω dt)⊗q` (left) or `q⊗Exp(ω dt)` (right): inputs `[q, ω, dt]`.
struct ExpUpdate {
    left: bool,
}

impl Kernel for ExpUpdate {
    fn n_in(&self) -> usize {
        8
    }
    fn n_out(&self) -> usize {
        4
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let (q, w, dt) = (q4(x), v3(&x[4..]), x[7]);
        let r = if self.left {
            exp_update_left(q, w, dt)
        } else {
            exp_update_right(q, w, dt)
        };
        r.write_to(out);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let (q, om, dt) = (q4(x), v3(&x[4..]), x[7]);
        let g = if self.left {
            exp_update_left_vjp(q, om, dt, q4(w))
        } else {
            exp_update_right_vjp(q, om, dt, q4(w))
        };
        d[..4].copy_from_slice(&g.q.to_array());
        d[4..7].copy_from_slice(&g.omega.to_array());
        d[7] = g.dt;
    }
}

/// `[sigmoid(s), exp3(v), normalize_quat(q), normalize_vec3(u), rotation_from_raw(r)]`.
struct Activations;

impl Kernel for Activations {
    fn n_in(&self) -> usize {
        15
    }
    fn n_out(&self) -> usize {
        20
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        out[0] = sigmoid(x[0]);
        exp3(v3(&x[1..])).write_to(&mut out[1..]);
        normalize_quat(q4(&x[4..])).write_to(&mut out[4..]);
        normalize_vec3(v3(&x[8..])).write_to(&mut out[8..]);
        out[11..].copy_from_slice(&rotation_from_raw(q4(&x[11..])).to_flat());
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        d[0] = sigmoid_vjp(x[0], w[0]);
        d[1..4].copy_from_slice(&exp3_vjp(v3(&x[1..]), v3(&w[1..])).to_array());
        d[4..8].copy_from_slice(&normalize_quat_vjp(q4(&x[4..]), q4(&w[4..])).to_array());
        d[8..11].copy_from_slice(&normalize_vec3_vjp(v3(&x[8..]), v3(&w[8..])).to_array());
        let g = Mat3::from_flat(core::array::from_fn(|k| w[11 + k]));
        d[11..].copy_from_slice(&rotation_from_raw_vjp(q4(&x[11..]), g).to_array());
    }
}

/// A rotation vector of angle `angle` along a random axis.
fn rotvec(rng: &mut SplitMix64, angle: f64) -> Vec<f64> {
    let a = Vec3::new(rng.normal(), rng.normal(), rng.normal());
    (a * (angle / a.norm())).to_array().to_vec()
}

pub(super) fn rows() -> Vec<GradRow> {
    let mut rng = SplitMix64::new(0x6d61_7468);
    let mut pts = |n: usize, lo: f64, hi: f64, k: usize| -> Vec<Vec<f64>> {
        (0..k).map(|_| uniform(&mut rng, n, lo, hi)).collect()
    };
    let cov = pts(7, -1.5, 1.0, 4);
    let sh: Vec<Vec<f64>> = pts(51, -0.8, 0.8, 3);
    let acts = pts(15, -1.5, 1.5, 4);
    let mut rng = SplitMix64::new(0x736f_3321);
    // Angles from tiny to just below π (and beyond, for the maps that allow it).
    let angles = [1e-7, 1e-3, 0.4, 1.7, 3.0, core::f64::consts::PI - 2e-3];
    let phis: Vec<Vec<f64>> = angles.iter().map(|&a| rotvec(&mut rng, a)).collect();
    let jl: Vec<Vec<f64>> = angles
        .iter()
        .map(|&a| {
            let mut x = rotvec(&mut rng, a);
            x.extend(uniform(&mut rng, 3, -1.0, 1.0));
            x
        })
        .collect();
    let upd: Vec<Vec<f64>> = angles
        .iter()
        .map(|&a| {
            let mut x = uniform(&mut rng, 4, -1.0, 1.0);
            x.extend(rotvec(&mut rng, a));
            x.push(rng.uniform(0.5, 1.0));
            x
        })
        .collect();
    vec![
        check_kernel("math: covariance_vjp", &Covariance, &cov, 1),
        check_kernel("math: sh_eval_vjp (degree 3)", &Sh, &sh, 2),
        check_kernel("math: exp_quat_vjp", &ExpMap, &phis, 3),
        check_kernel("math: jl_inv_mul_vjp", &JlInv, &jl, 4),
        check_kernel(
            "math: exp_update_left_vjp",
            &ExpUpdate { left: true },
            &upd,
            5,
        ),
        check_kernel(
            "math: exp_update_right_vjp",
            &ExpUpdate { left: false },
            &upd,
            6,
        ),
        check_kernel(
            "math: activations (sigmoid, exp3, normalize, R(q))",
            &Activations,
            &acts,
            7,
        ),
    ]
}
