//! `evogs export`: the Gaussians at time `t` as a standard 3DGS `.ply` (`docs/splatting.md`
//! §15):
//! `x y z nx ny nz f_dc_0..2 f_rest_0..(3(K−1)−1) opacity scale_0..2 rot_0..3`, binary
//! little-endian floats; `f_rest` channel-major (all R, then G, then B); opacity as a logit,
//! scales as logs, rotations as raw (w, x, y, z).

use super::paths::RunFolder;
use super::train::CommandError;
use crate::data::ply::PlyTable;
use crate::run::checkpoint;
use evogs_splat::Splats;
use std::path::Path;

/// The 3DGS property table of a set of Gaussians.
#[must_use]
pub fn gaussians_table(s: &Splats<f32>) -> PlyTable {
    let n = s.len();
    let k = s.coeffs_per_gaussian();
    let mut names: Vec<String> = [
        "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
    ]
    .iter()
    .map(|v| (*v).to_string())
    .collect();
    names.extend((0..3 * (k - 1)).map(|i| format!("f_rest_{i}")));
    names.push("opacity".into());
    names.extend((0..3).map(|i| format!("scale_{i}")));
    names.extend((0..4).map(|i| format!("rot_{i}")));
    let mut columns = vec![Vec::with_capacity(n); names.len()];
    for i in 0..n {
        let mut row: Vec<f64> = Vec::with_capacity(names.len());
        row.extend(s.means[i].to_array().map(f64::from));
        row.extend([0.0; 3]);
        let sh = s.sh_coeffs(i);
        row.extend(sh[0].map(f64::from));
        for c in 0..3 {
            for j in 1..k {
                row.push(f64::from(sh[j][c]));
            }
        }
        row.push(f64::from(s.opacity_logits[i]));
        row.extend(s.log_scales[i].to_array().map(f64::from));
        row.extend(s.quats[i].to_array().map(f64::from));
        for (col, v) in columns.iter_mut().zip(row) {
            col.push(v);
        }
    }
    PlyTable {
        names,
        columns,
        len: n,
    }
}

/// Runs `evogs export`.
///
/// # Errors
/// Unreadable run or unwritable output.
pub fn export(run: &Path, t: f64, out: &Path) -> Result<usize, CommandError> {
    let l = checkpoint::load_model(&RunFolder::new(run).checkpoint())
        .map_err(CommandError::from_display)?;
    let mut model = l.model;
    model
        .check_time(t)
        .map_err(|e| CommandError(format!("--time: {e}")))?;
    let mut s = Splats::default();
    let mut stepper = None;
    let _tape = model.splats_at(t, &mut stepper, &mut s);
    gaussians_table(&s)
        .write_binary(out)
        .map_err(|e| CommandError(format!("{}: cannot write: {e}", out.display())))?;
    Ok(s.len())
}
