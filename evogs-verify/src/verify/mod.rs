//! `evogs verify`: recompute reference-vector files with the library in f64 and compare.
//!
//! A file's kind is recognised by its content (keys), never by its name:
//!
//! | kind | recognised by | recomputed with |
//! |---|---|---|
//! | raster | `case.loss.W_rgb` | `render`, `render_vjp` (classic or antialiased) |
//! | projection | `case.inputs.viewmat` and `case.outputs.conics`, no `case.loss` | `project`, `project_vjp` |
//! | ode | `case.runs[].results` | `integrate_trajectory`, `discrete_adjoint`, `continuous_adjoint` |
//! | ode adaptive | `problems[].scipy_rk45` | `adaptive::AdaptiveSolver` (`solve`, dense output, `adjoint`) |
//! | so3 | `rotvec_cases` | `so3`, `so3_jacobians`, `so3_coeffs`, `update` |
//! | se3 | `cases[].xi` | `Se3`, `se3`, `se3_jacobians` |
//! | metrics | `cases[].ssim_3dgs` | `metrics`, `SsimWorkspace`, [`metrics::ssim_skimage`] |
//!
//! Every quantity of a file gets a [`Row`] (aggregated over the file's cases, naming the
//! worst case and entry); tolerances are the f64 column of the oracle's SCHEMA.md, stated
//! per row. A quantity that cannot be recomputed (an unknown method, field or output) is a
//! failing row, never skipped. An unreadable file, one of unknown kind, or a missing field
//! or wrong shape is a [`VerifyError`] naming the file (and the JSON path).
//!
//! ```no_run
//! let report = evogs_verify::verify::verify_file("tests/data/oracle/so3_shared_cases.json".as_ref())?;
//! println!("{report}");
//! assert!(report.passed());
//! # Ok::<(), evogs_verify::verify::VerifyError>(())
//! ```

pub mod decisions;
pub mod expm;
mod json;
pub mod metrics;
mod ode;
mod ode_adaptive;
mod projection;
mod raster;
mod report;
mod scene;
mod se3;
mod so3;

pub use json::Malformed;
pub use report::{FileReport, Kind, LEGEND, Row, Rule};

use json::Node;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Why a file could not be verified.
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    /// The file could not be read: missing, not a regular file, larger than a
    /// reference-vector file can be, or not UTF-8 text.
    #[error(transparent)]
    Read(#[from] evogs::bounded::ReadError),
    /// The file is not JSON.
    #[error("{}: not valid JSON: {message}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// The content matches none of the known reference-vector kinds.
    #[error(
        "{}: not a known reference-vector file (top-level keys: {found}); expected \
         `case.loss.W_rgb` (raster), `case.inputs.viewmat` with `case.outputs.conics` \
         (projection), `case.runs[].results` (ode), `problems[].scipy_rk45` (ode adaptive), \
         `rotvec_cases` (so3), `cases[].xi` (se3) or `cases[].ssim_3dgs` (metrics)",
        path.display()
    )]
    UnknownKind {
        /// The file.
        path: PathBuf,
        /// Its top-level keys.
        found: String,
    },
    /// A field is missing or has the wrong type or shape.
    #[error("{}: malformed {kind} file at `{}`: expected {}", path.display(), detail.path, detail.expected)]
    Malformed {
        /// The file.
        path: PathBuf,
        /// The kind it was recognised as.
        kind: Kind,
        /// Where and what.
        detail: Malformed,
    },
}

/// Recognises the kind of a parsed reference file by its keys.
#[must_use]
pub fn detect_kind(v: &Value) -> Option<Kind> {
    let case = v.get("case");
    fn has(o: Option<&Value>, k: &str) -> bool {
        o.and_then(|o| o.get(k)).is_some()
    }
    fn first(o: Option<&Value>) -> Option<&Value> {
        o.and_then(Value::as_array).and_then(|a| a.first())
    }
    if has(case.and_then(|c| c.get("loss")), "W_rgb") {
        return Some(Kind::Raster);
    }
    if has(case.and_then(|c| c.get("inputs")), "viewmat")
        && has(case.and_then(|c| c.get("outputs")), "conics")
        && !has(case, "loss")
    {
        return Some(Kind::Projection);
    }
    if has(first(case.and_then(|c| c.get("runs"))), "results") {
        return Some(Kind::Ode);
    }
    if has(first(v.get("problems")), "scipy_rk45") {
        return Some(Kind::OdeAdaptive);
    }
    if v.get("rotvec_cases").is_some() {
        return Some(Kind::So3);
    }
    if has(first(v.get("cases")), "xi") {
        return Some(Kind::Se3);
    }
    if has(first(v.get("cases")), "ssim_3dgs") {
        return Some(Kind::Metrics);
    }
    None
}

/// Verifies an already parsed file; `path` only names it in the report and errors.
///
/// # Errors
/// [`VerifyError::UnknownKind`] or [`VerifyError::Malformed`].
pub fn verify_value(path: &Path, v: &Value) -> Result<FileReport, VerifyError> {
    let Some(kind) = detect_kind(v) else {
        let found = v.as_object().map_or_else(
            || "none: not an object".to_string(),
            |o| o.keys().cloned().collect::<Vec<_>>().join(", "),
        );
        return Err(VerifyError::UnknownKind {
            path: path.to_path_buf(),
            found,
        });
    };
    let root = Node::root(v);
    let result = match kind {
        Kind::Projection => projection::verify(&root),
        Kind::Raster => raster::verify(&root),
        Kind::Ode => ode::verify(&root),
        Kind::OdeAdaptive => ode_adaptive::verify(&root),
        Kind::So3 => so3::verify(&root),
        Kind::Se3 => se3::verify(&root),
        Kind::Metrics => metrics::verify(&root),
    };
    let (cases, mut rows) = result.map_err(|detail| VerifyError::Malformed {
        path: path.to_path_buf(),
        kind,
        detail,
    })?;
    if let Some(sv) = v.get("schema_version")
        && sv.as_u64() != Some(1)
    {
        rows.push(Row {
            quantity: "schema_version".to_string(),
            count: 1,
            max_abs: 0.0,
            max_rel: 0.0,
            rule: Rule::NotComputed,
            passed: false,
            detail: format!("version {sv}: only version 1 is implemented"),
        });
    }
    Ok(FileReport {
        path: path.to_path_buf(),
        kind,
        cases,
        rows,
    })
}

/// Reads, recognises and verifies one reference file.
///
/// # Errors
/// See [`VerifyError`]: every error names the file.
pub fn verify_file(path: &Path) -> Result<FileReport, VerifyError> {
    let text = evogs::bounded::read_text(
        path,
        evogs::bounded::METADATA_BYTES,
        "a reference-vector file",
    )?;
    let v: Value = serde_json::from_str(&text).map_err(|e| VerifyError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    verify_value(path, &v)
}
