//! The camera and the Gaussians of a projection or raster reference case, converted to the
//! library's parameterisation (log-scales, opacity logits), and the conversions of the
//! library's gradients back to the file's parameters (linear scales, activated opacities).

use super::json::{ANY, Malformed, Node, Res};
use evogs_math::activation::{logit, sigmoid};
use evogs_math::{Quat, Vec3};
use evogs_splat::{CameraGrad, PinholeCamera, Splats};

/// `case.name`, or `case` if the file has none.
pub(crate) fn case_name(case: &Node<'_>) -> Res<String> {
    Ok(match case.opt("name") {
        Some(v) => v.str()?.to_string(),
        None => "case".to_string(),
    })
}

/// The camera of `case.inputs` (`viewmat`, `K`, size, near and far planes).
pub(crate) fn camera(inputs: &Node<'_>) -> Res<PinholeCamera<f64>> {
    let vm = inputs.get("viewmat")?;
    PinholeCamera::from_viewmat(
        vm.mat4()?,
        inputs.get("K")?.mat3()?,
        inputs.get("width")?.usize()?,
        inputs.get("height")?.usize()?,
        inputs.get("near_plane")?.f64()?,
        inputs.get("far_plane")?.f64()?,
    )
    .map_err(|e| Malformed {
        path: vm.path().to_string(),
        expected: format!("a usable camera with K, size and near/far ({e})"),
    })
}

/// The Gaussians of `case.inputs`: `means`, `quats`, `scales` (> 0), `opacities` (in
/// (0, 1)) and, with `sh_degree`, `sh_coeffs` (a zero DC term otherwise).
pub(crate) fn splats(inputs: &Node<'_>) -> Res<Splats<f64>> {
    let means = inputs.get("means")?.nums(&[ANY, 3])?;
    let n = means.len() / 3;
    let quats = inputs.get("quats")?.nums(&[n, 4])?;
    let scales_node = inputs.get("scales")?;
    let scales = scales_node.nums(&[n, 3])?;
    let op_node = inputs.get("opacities")?;
    let opacities = op_node.nums(&[n])?;
    let degree = match inputs.opt("sh_degree") {
        Some(d) => d.usize()?,
        None => 0,
    };
    if degree > 3 {
        return Err(Malformed {
            path: inputs.get("sh_degree")?.path().to_string(),
            expected: "an SH degree of at most 3".to_string(),
        });
    }
    let k = (degree + 1) * (degree + 1);
    let sh = match inputs.opt("sh_coeffs") {
        Some(c) => c.nums(&[n, k, 3])?,
        None => vec![0.0; n * k * 3],
    };
    if scales.iter().any(|&s| s <= 0.0) {
        return Err(Malformed {
            path: scales_node.path().to_string(),
            expected: "positive standard deviations".to_string(),
        });
    }
    if opacities.iter().any(|&o| o <= 0.0 || o >= 1.0) {
        return Err(Malformed {
            path: op_node.path().to_string(),
            expected: "opacities in (0, 1)".to_string(),
        });
    }
    let mut s = Splats::new(degree);
    let mut coeffs = vec![[0.0; 3]; k];
    for i in 0..n {
        for (j, c) in coeffs.iter_mut().enumerate() {
            let o = 3 * (i * k + j);
            *c = [sh[o], sh[o + 1], sh[o + 2]];
        }
        s.push(
            Vec3::from_slice(&means[3 * i..]),
            Vec3::from_slice(&scales[3 * i..]).map(f64::ln),
            Quat::from_slice(&quats[4 * i..]),
            logit(opacities[i]),
            &coeffs,
        );
    }
    Ok(s)
}

/// `∂L/∂s` (linear scales) from `∂L/∂ŝ` (log-scales): `(∂L/∂ŝ)/s`.
pub(crate) fn scale_grads(s: &Splats<f64>, d_log_scales: &[Vec3<f64>]) -> Vec<f64> {
    s.log_scales
        .iter()
        .zip(d_log_scales)
        .flat_map(|(ls, d)| [d.x / ls.x.exp(), d.y / ls.y.exp(), d.z / ls.z.exp()])
        .collect()
}

/// `∂L/∂o` (activated opacities) from `∂L/∂ô` (logits): `(∂L/∂ô)/(o(1 − o))`.
pub(crate) fn opacity_grads(s: &Splats<f64>, d_logits: &[f64]) -> Vec<f64> {
    s.opacity_logits
        .iter()
        .zip(d_logits)
        .map(|(&l, &d)| {
            let o = sigmoid(l);
            d / (o * (1.0 - o))
        })
        .collect()
}

/// The two camera gradients of the files: `viewmat` (4×4, row-major) and `pose_left_se3`.
pub(crate) fn camera_grads(g: &CameraGrad<f64>, cam: &PinholeCamera<f64>) -> (Vec<f64>, Vec<f64>) {
    (g.to_viewmat().concat(), g.to_pose_left_se3(cam).to_vec())
}

/// Flattens 3-vectors.
pub(crate) fn flat3(v: &[Vec3<f64>]) -> Vec<f64> {
    v.iter().flat_map(|x| x.to_array()).collect()
}

/// Flattens quaternions `(w, x, y, z)`.
pub(crate) fn flat4(v: &[Quat<f64>]) -> Vec<f64> {
    v.iter().flat_map(|x| x.to_array()).collect()
}

/// Keeps the rows (of `width` entries) where `mask` is set.
pub(crate) fn masked(v: &[f64], width: usize, mask: &[bool]) -> Vec<f64> {
    v.chunks(width)
        .zip(mask)
        .filter(|(_, m)| **m)
        .flat_map(|(r, _)| r.to_vec())
        .collect()
}

/// Names of the entries of a masked comparison: the Gaussian index and component.
pub(crate) fn masked_name(width: usize, mask: &[bool]) -> impl Fn(usize) -> String {
    let idx: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
    move |k| {
        let g = idx.get(k / width.max(1)).copied().unwrap_or(0);
        if width <= 1 {
            format!("[{g}]")
        } else {
            format!("[{g}][{}]", k % width)
        }
    }
}
