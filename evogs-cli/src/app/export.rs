//! `evogs export`: the Gaussians at time `t` as a standard 3DGS `.ply` (`docs/splatting.md`
//! §15):
//! `x y z nx ny nz f_dc_0..2 f_rest_0..(3(K−1)−1) opacity scale_0..2 rot_0..3`, binary
//! little-endian floats; `f_rest` channel-major (all R, then G, then B); opacity as a logit,
//! scales as logs, rotations as raw (w, x, y, z).

use super::error::{CommandError, Context as _};
use super::paths::RunFolder;
use super::render::frame_time;
use super::sequence_folder::SequenceFiles;
use super::{Reporter, interrupt};
use evogs::data::ply::PlyTable;
use evogs::model::Model;
use evogs::run::checkpoint;
use evogs_splat::Splats;
use std::path::{Path, PathBuf};

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

fn load(run: &Path) -> Result<Model<f32>, CommandError> {
    checkpoint::load_model(&RunFolder::new(run).checkpoint())
        .map(|l| l.model)
        .map_err(CommandError::new)
}

/// Runs `evogs export --time T`: the Gaussians at `t` into one `.ply`; returns their count.
///
/// # Errors
/// Unreadable run, a time out of reach, or unwritable output.
pub fn export(run: &Path, t: f64, out: &Path) -> Result<usize, CommandError> {
    let mut model = load(run)?;
    model
        .check_time(t)
        .map_err(|e| CommandError::new(format!("--time: {e}")))?;
    let mut s = Splats::default();
    let mut stepper = None;
    let _tape = model.splats_at(t, &mut stepper, &mut s);
    gaussians_table(&s)
        .write_binary(out)
        .doing(out, "cannot write")?;
    Ok(s.len())
}

/// What `evogs export --times` wrote.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sequence {
    /// The `.ply` files, relative to the folder (`frame_0000.ply`, ...).
    pub files: Vec<String>,
    /// The time of each file.
    pub times: Vec<f64>,
    /// Gaussians per file.
    pub gaussians: usize,
}

/// The name of the index file `export_sequence` writes beside the frames.
pub const SEQUENCE_FILE: &str = "sequence.json";

/// The files of an exported sequence.
const PLY_FILES: SequenceFiles = SequenceFiles {
    prefix: "frame_",
    ext: "ply",
    others: &[SEQUENCE_FILE],
};

/// Runs `evogs export --times A:B:N --out DIR`: one 3DGS `.ply` per time (`frame_NNNN.ply`,
/// the sequence viewers such as `SuperSplat` import) and `sequence.json` listing the files and
/// their times, every file written atomically; the index comes last, so a folder with an
/// index holds the whole sequence. The sequence owns the folder: an earlier one's files are
/// refused, or removed with `force`. An interrupt stops after the current file.
///
/// # Errors
/// Unreadable run, times out of reach, an unwritable folder, an earlier sequence there
/// without `force`, or an interrupt.
pub fn export_sequence(
    run: &Path,
    times: (f64, f64, usize),
    out: &Path,
    force: bool,
    rep: &mut dyn Reporter,
) -> Result<Sequence, CommandError> {
    let mut model = load(run)?;
    for t in [times.0, times.1] {
        model
            .check_time(t)
            .map_err(|e| CommandError::new(format!("--times: {e}")))?;
    }
    let _lock = super::lock::FolderLock::acquire(out, "export --times")?;
    PLY_FILES.claim(out, force)?;
    let n = times.2;
    let mut seq = Sequence {
        files: Vec::with_capacity(n),
        times: Vec::with_capacity(n),
        gaussians: model.len(),
    };
    let mut s = Splats::default();
    let mut stepper = None;
    rep.start("export", n as u64);
    for i in 0..n {
        if interrupt::take() {
            return Err(CommandError::new(format!(
                "interrupted: {i} of {n} files written to {}; no {SEQUENCE_FILE}",
                out.display()
            )));
        }
        let t = frame_time(times, i);
        let _tape = model.splats_at(t, &mut stepper, &mut s);
        let name = format!("frame_{i:04}.ply");
        let path: PathBuf = out.join(&name);
        gaussians_table(&s)
            .write_binary(&path)
            .doing(&path, "cannot write")?;
        seq.files.push(name);
        seq.times.push(t);
        rep.progress(i as u64 + 1, &format!("t = {t:.3}"));
    }
    rep.finish();
    let json = serde_json::to_string_pretty(&seq).unwrap_or_default();
    evogs::atomic::write_atomic_named(&out.join(SEQUENCE_FILE), json.as_bytes())
        .map_err(CommandError::new)?;
    Ok(seq)
}
