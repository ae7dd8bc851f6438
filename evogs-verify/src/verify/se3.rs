//! `se3_*` files: the SE(3) exponential and logarithm, the Jacobians, `Ad`, `ad`, the inverse,
//! a composition and the action on a point, against scipy `expm` and 50-digit mpmath sums
//! `Jl = Σ ad(ξ)ⁿ/(n+1)!` (SCHEMA.md, `se3_shared_cases.json`).
//!
//! Every quantity at 1e-12 relative to max(1, |ref|), the schema's suggestion. The file stores
//! the rotation's quaternion with w ≥ 0, so the recomputed one is folded the same way
//! (`Se3::exp` keeps the sign of `Exp(φ)`, negative beyond π). `log_of_matrix` (present where
//! the angle is below π − 1e-6) is recomputed from the file's own `matrix`, not from ξ.

use super::json::{Node, Res};
use super::report::{Row, Rule, Tally, index_name};
use evogs_math::se3::ad;
use evogs_math::se3_jacobians::{
    left_jacobian, left_jacobian_inv, right_jacobian, right_jacobian_inv,
};
use evogs_math::{Mat6, Se3, Vec3, Vec6};

const TOL: Rule = Rule::Rel {
    tol: 1e-12,
    floor: 1.0,
};

fn m36(m: Mat6<f64>) -> Vec<f64> {
    m.m.as_flattened().to_vec()
}

fn m16(m: [[f64; 4]; 4]) -> Vec<f64> {
    m.as_flattened().to_vec()
}

fn case(t: &mut Tally, c: &Node<'_>, label: &str) -> Res<()> {
    let xi = Vec6::from_slice(&c.get("xi")?.nums(&[6])?);
    let x = Se3::exp(xi);
    let (v, m4, m6) = (index_name(1), index_name(4), index_name(6));
    t.floats(
        "angle",
        TOL,
        label,
        &[xi.tail.norm()],
        &[c.get("angle")?.f64()?],
        &v,
    );
    t.floats(
        "matrix",
        TOL,
        label,
        &m16(x.to_matrix()),
        &c.get("matrix")?.nums(&[4, 4])?,
        &m4,
    );
    let q = if x.quat().w < 0.0 {
        -x.quat()
    } else {
        x.quat()
    };
    t.floats(
        "quat_wxyz",
        TOL,
        label,
        &q.to_array(),
        &c.get("quat_wxyz")?.vec4()?,
        &v,
    );
    t.floats(
        "translation",
        TOL,
        label,
        &x.translation().to_array(),
        &c.get("translation")?.vec3()?,
        &v,
    );
    for (key, m) in [
        ("Jl", left_jacobian(xi)),
        ("Jr", right_jacobian(xi)),
        ("Jl_inv", left_jacobian_inv(xi)),
        ("Jr_inv", right_jacobian_inv(xi)),
        ("Ad", x.adjoint()),
        ("ad", ad(xi)),
    ] {
        t.floats(key, TOL, label, &m36(m), &c.get(key)?.nums(&[6, 6])?, &m6);
    }
    t.floats(
        "inverse",
        TOL,
        label,
        &m16(x.inverse().to_matrix()),
        &c.get("inverse")?.nums(&[4, 4])?,
        &m4,
    );
    let other = Se3::exp(Vec6::from_slice(&c.get("other_xi")?.nums(&[6])?));
    t.floats(
        "compose_with_other",
        TOL,
        label,
        &m16((x * other).to_matrix()),
        &c.get("compose_with_other")?.nums(&[4, 4])?,
        &m4,
    );
    let p = Vec3::from_array(c.get("point")?.vec3()?);
    t.floats(
        "act_on_point",
        TOL,
        label,
        &x.act(p).to_array(),
        &c.get("act_on_point")?.vec3()?,
        &v,
    );
    if let Some(want) = c.opt("log_of_matrix") {
        let log = Se3::from_matrix(&c.get("matrix")?.mat4()?).log();
        t.floats(
            "log_of_matrix",
            TOL,
            label,
            &log.to_array(),
            &want.nums(&[6])?,
            &v,
        );
    }
    Ok(())
}

/// Recomputes an SE(3) file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let mut t = Tally::default();
    let cases = root.get("cases")?.items()?;
    for (i, c) in cases.iter().enumerate() {
        let kind = c.get("kind")?.str()?;
        case(&mut t, c, &format!("cases[{i}] ({kind})"))?;
    }
    Ok((cases.len(), t.into_rows()))
}
