//! `so3_*` files: exp/log maps, Jacobians, their coefficients and quaternion updates against
//! scipy `Rotation` and 50-digit mpmath values (SCHEMA.md, "so3").
//!
//! Tolerance 1e-13 absolute for every vector, quaternion and matrix (also the log of a
//! matrix near π: `log_matrix` extracts the axis from the quaternion of the matrix, not from
//! `(R − Rᵀ)/(2 sin θ)`, so it does not lose the ~1e-8 of the naive formula); the Jacobian
//! coefficients `A, B, D` 1e-13 relative. Where `log_sign_ambiguous` (θ = π) either sign of
//! the logarithm is accepted.

use super::json::{Node, Res};
use super::report::{Row, Rule, Tally, index_name};
use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::so3_coeffs::{jinv_coeff, one_minus_cos_over_sq, theta_minus_sin_over_cube};
use evogs_math::so3_jacobians::{
    left_jacobian, left_jacobian_inv, right_jacobian, right_jacobian_inv,
};
use evogs_math::update::{exp_update_left, exp_update_right};
use evogs_math::{Mat3, Quat, Vec3};

const TOL: Rule = Rule::Abs(1e-13);
const COEFF: Rule = Rule::Rel {
    tol: 1e-13,
    floor: 1e-3,
};

fn m9(m: Mat3<f64>) -> Vec<f64> {
    m.to_flat().to_vec()
}

/// `±v`, whichever is closer to `want` (for the θ = π logarithms).
fn closer_sign(v: Vec3<f64>, want: [f64; 3]) -> Vec3<f64> {
    let w = Vec3::from_array(want);
    if (v + w).norm() < (v - w).norm() {
        -v
    } else {
        v
    }
}

fn rotvec_case(t: &mut Tally, c: &Node<'_>, label: &str) -> Res<()> {
    let phi = Vec3::from_array(c.get("rotvec")?.vec3()?);
    let ambiguous = c.get("log_sign_ambiguous")?.bool()?;
    let q_ref = c.get("quat_wxyz")?.vec4()?;
    let m_ref = c.get("matrix")?.mat3()?;
    let v3 = index_name(1);
    let v33 = index_name(3);
    t.floats(
        "angle",
        TOL,
        label,
        &[phi.norm()],
        &[c.get("angle")?.f64()?],
        &v3,
    );
    t.floats(
        "exp quat_wxyz",
        TOL,
        label,
        &exp_quat(phi).to_array(),
        &q_ref,
        &v3,
    );
    t.floats(
        "exp matrix",
        TOL,
        label,
        &m9(exp_matrix(phi)),
        &m_ref.concat(),
        &v33,
    );
    for (key, got) in [
        ("log_of_quat", log_quat(Quat::from_array(q_ref))),
        ("log_of_matrix", log_matrix(Mat3::from_rows(m_ref))),
    ] {
        let want = c.get(key)?.vec3()?;
        let got = if ambiguous {
            closer_sign(got, want)
        } else {
            got
        };
        t.floats(key, TOL, label, &got.to_array(), &want, &v3);
    }
    for (key, m) in [
        ("Jl", left_jacobian(phi)),
        ("Jr", right_jacobian(phi)),
        ("Jl_inv", left_jacobian_inv(phi)),
        ("Jr_inv", right_jacobian_inv(phi)),
    ] {
        t.floats(key, TOL, label, &m9(m), &c.get(key)?.mat3()?.concat(), &v33);
    }
    let co = c.get("jacobian_coeffs")?;
    let t2 = phi.norm_squared();
    for (key, got) in [
        ("A", one_minus_cos_over_sq(t2)),
        ("B", theta_minus_sin_over_cube(t2)),
        ("D", jinv_coeff(t2)),
    ] {
        t.floats(
            &format!("jacobian_coeffs.{key}"),
            COEFF,
            label,
            &[got],
            &[co.get(key)?.f64()?],
            &|_| String::new(),
        );
    }
    Ok(())
}

fn update_case(t: &mut Tally, c: &Node<'_>, label: &str) -> Res<()> {
    let q = Quat::from_array(c.get("q")?.vec4()?);
    let w = Vec3::from_array(c.get("omega")?.vec3()?);
    let dt = c.get("dt")?.f64()?;
    let right = exp_update_right(q, w, dt);
    let left = exp_update_left(q, w, dt);
    let v = index_name(1);
    let m = index_name(3);
    for (key, got) in [
        ("dq_exp", exp_quat(w * dt)),
        ("q_right", right),
        ("q_left", left),
    ] {
        t.floats(
            &format!("update {key}"),
            TOL,
            label,
            &got.to_array(),
            &c.get(key)?.vec4()?,
            &v,
        );
    }
    for (key, got) in [("R_right", right), ("R_left", left)] {
        t.floats(
            &format!("update {key}"),
            TOL,
            label,
            &m9(got.to_rotation_matrix()),
            &c.get(key)?.mat3()?.concat(),
            &m,
        );
    }
    Ok(())
}

/// Recomputes an SO(3) file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let mut t = Tally::default();
    let rot = root.get("rotvec_cases")?.items()?;
    for (i, c) in rot.iter().enumerate() {
        let kind = c.get("kind")?.str()?;
        rotvec_case(&mut t, c, &format!("rotvec_cases[{i}] ({kind})"))?;
    }
    let upd = match root.opt("quat_update_cases") {
        Some(u) => u.items()?,
        None => Vec::new(),
    };
    for (i, c) in upd.iter().enumerate() {
        update_case(&mut t, c, &format!("quat_update_cases[{i}]"))?;
    }
    Ok((rot.len() + upd.len(), t.into_rows()))
}
