//! The per-file result of `evogs verify`: one [`Row`] per recomputed quantity (aggregated
//! over the file's cases), and [`FileReport`], printed as an aligned table.
//!
//! Error measures of a row, over every compared entry `a` (ours) against `r` (reference):
//!
//! ```text
//! max abs = max |a − r|
//! max rel = max |a − r| / max(f, |r|)        for a Rule::Rel { tol, floor: f }  (pass: ≤ tol)
//!         = max |a − r| / max |r|            for a Rule::Abs(tol)  (pass: max abs ≤ tol)
//!         = max |a − r| / |r|                for a Rule::Propagated (pass: each entry within
//!                                            its own propagated allowance)
//! exact   : integers and booleans must be equal; the row counts the mismatches
//! ```
//!
//! A quantity that cannot be recomputed gets a failing row with the reason.

use core::fmt;
use std::path::PathBuf;

/// How to read a [`FileReport`] table (printed once by `evogs verify`).
pub const LEGEND: &str = "\
a = recomputed, r = reference; n = compared entries over all cases of the file
max abs = max |a - r|
max rel = max |a - r|/max(f, |r|) for tolerance `t·max(f,|r|)` (pass: max rel <= t),
          max |a - r|/max |r| for `abs t` (pass: max abs <= t),
          max |a - r|/|r| for `propagated` (pass: every entry within its own allowance)
exact   = integers/booleans must be equal (max abs = largest difference)";

/// How a quantity is compared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    /// `|a − r| ≤ tol` for every entry.
    Abs(f64),
    /// `|a − r| ≤ tol·max(floor, |r|)` for every entry.
    Rel {
        /// Relative tolerance.
        tol: f64,
        /// Floor of the reference magnitude (1 where the schema says "relative to
        /// `max(1, |ref|)`", a small number for "relative").
        floor: f64,
    },
    /// A quantity derived from others that are known to absolute precision `δ`: each
    /// entry's allowance is `δ` propagated through the derivation (the row's docs say how).
    Propagated(f64),
    /// Integers or booleans, equal entry by entry.
    Exact,
    /// Nothing could be compared (the row explains why); always a failure.
    NotComputed,
}

impl fmt::Display for Rule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Abs(t) => write!(f, "abs {t:.0e}"),
            Self::Rel { tol, floor } if floor >= 1.0 => write!(f, "{tol:.0e}·max(1,|r|)"),
            Self::Rel { tol, floor } => write!(f, "{tol:.0e}·max({floor:.0e},|r|)"),
            Self::Propagated(d) => write!(f, "δ={d:.0e} propagated"),
            Self::Exact => f.write_str("exact"),
            Self::NotComputed => f.write_str("-"),
        }
    }
}

/// One recomputed quantity of a file.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// What was compared (e.g. `grads.total.params.means`).
    pub quantity: String,
    /// Number of compared entries (over all cases).
    pub count: usize,
    /// Largest absolute error (for exact rows: the largest integer difference).
    pub max_abs: f64,
    /// Largest relative error (see the module docs); for exact rows the number of
    /// mismatches.
    pub max_rel: f64,
    /// The comparison rule.
    pub rule: Rule,
    /// Whether every entry is within the rule.
    pub passed: bool,
    /// Where the worst entry is (case and index), or why nothing was computed.
    pub detail: String,
}

/// Which reference-vector schema a file follows (recognised by its keys).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `projection_*`: EWA projection outputs and VJPs.
    Projection,
    /// `raster_*`: the full chain projection → SH → compositing with gradients.
    Raster,
    /// `ode_*`: fixed-grid integrators, discrete and continuous adjoints.
    Ode,
    /// `ode_adaptive_*`: adaptive pairs, dense output and the adaptive discrete adjoint.
    OdeAdaptive,
    /// `so3_*`: exp/log maps, Jacobians and quaternion updates.
    So3,
    /// `se3_*`: SE(3) exp/log, Jacobians, adjoints, inverse, composition and action.
    Se3,
    /// `metrics_*`: MSE, PSNR, SSIM (3DGS and scikit-image) and the SSIM gradient.
    Metrics,
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Projection => "projection",
            Self::Raster => "raster",
            Self::Ode => "ode",
            Self::OdeAdaptive => "ode adaptive",
            Self::So3 => "so3",
            Self::Se3 => "se3",
            Self::Metrics => "metrics",
        })
    }
}

/// The result of verifying one file.
#[derive(Clone, Debug, PartialEq)]
pub struct FileReport {
    /// The file.
    pub path: PathBuf,
    /// Its schema.
    pub kind: Kind,
    /// Number of cases (or runs × results) recomputed.
    pub cases: usize,
    /// One row per quantity.
    pub rows: Vec<Row>,
}

impl FileReport {
    /// `true` if every row passed (and there is at least one).
    #[must_use]
    pub fn passed(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.passed)
    }

    /// The rows that failed.
    pub fn failures(&self) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(|r| !r.passed)
    }
}

fn sci(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else {
        format!("{v:.2e}")
    }
}

impl fmt::Display for FileReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} ({} reference vectors, {} case{})",
            self.path.display(),
            self.kind,
            self.cases,
            if self.cases == 1 { "" } else { "s" }
        )?;
        let qw = self
            .rows
            .iter()
            .map(|r| r.quantity.chars().count())
            .max()
            .unwrap_or(8)
            .max(8);
        writeln!(
            f,
            "  {:<qw$}  {:>6}  {:>9}  {:>9}  {:<21}  {:<4}  worst entry / note",
            "quantity", "n", "max abs", "max rel", "tolerance", "ok"
        )?;
        for r in &self.rows {
            let (abs, rel) = match r.rule {
                Rule::Exact => (sci(r.max_abs), "-".to_string()),
                Rule::NotComputed => ("-".to_string(), "-".to_string()),
                _ => (sci(r.max_abs), sci(r.max_rel)),
            };
            writeln!(
                f,
                "  {:<qw$}  {:>6}  {:>9}  {:>9}  {:<21}  {:<4}  {}",
                r.quantity,
                r.count,
                abs,
                rel,
                r.rule.to_string(),
                if r.passed { "pass" } else { "FAIL" },
                if r.rule == Rule::Exact && r.passed {
                    "all equal"
                } else {
                    &r.detail
                }
            )?;
        }
        let failed = self.failures().count();
        write!(
            f,
            "  {}: {} quantities, {} failed",
            if self.passed() { "PASS" } else { "FAIL" },
            self.rows.len(),
            failed
        )
    }
}

/// Collects rows, merging comparisons of the same quantity over several cases.
#[derive(Debug, Default)]
pub(crate) struct Tally {
    rows: Vec<Row>,
    /// Worst ratio (error / allowance) per row, to pick the worst case.
    worst: Vec<f64>,
    /// Largest reference magnitude per row (for `Rule::Abs`).
    ref_max: Vec<f64>,
}

impl Tally {
    fn slot(&mut self, quantity: &str, rule: Rule) -> usize {
        if let Some(i) = self.rows.iter().position(|r| r.quantity == quantity) {
            return i;
        }
        self.rows.push(Row {
            quantity: quantity.to_string(),
            count: 0,
            max_abs: 0.0,
            max_rel: 0.0,
            rule,
            passed: true,
            detail: String::new(),
        });
        self.worst.push(-1.0);
        self.ref_max.push(0.0);
        self.rows.len() - 1
    }

    /// Compares floats; `name(i)` names entry `i` for the worst-case detail.
    pub(crate) fn floats(
        &mut self,
        quantity: &str,
        rule: Rule,
        case: &str,
        mine: &[f64],
        reference: &[f64],
        name: &dyn Fn(usize) -> String,
    ) {
        let allow = |_: usize, r: f64| match rule {
            Rule::Abs(t) => t,
            Rule::Rel { tol, floor } => tol * r.abs().max(floor),
            _ => 0.0,
        };
        self.compare(quantity, rule, case, mine, reference, &allow, name);
    }

    /// Compares floats with a per-entry allowance `allow[i]` (a [`Rule::Propagated`] row).
    pub(crate) fn floats_propagated(
        &mut self,
        quantity: &str,
        delta: f64,
        case: &str,
        mine: &[f64],
        reference: &[f64],
        allow: &[f64],
        name: &dyn Fn(usize) -> String,
    ) {
        let allow = |i: usize, _: f64| allow.get(i).copied().unwrap_or(0.0);
        self.compare(
            quantity,
            Rule::Propagated(delta),
            case,
            mine,
            reference,
            &allow,
            name,
        );
    }

    fn compare(
        &mut self,
        quantity: &str,
        rule: Rule,
        case: &str,
        mine: &[f64],
        reference: &[f64],
        allow: &dyn Fn(usize, f64) -> f64,
        name: &dyn Fn(usize) -> String,
    ) {
        let k = self.slot(quantity, rule);
        if self.length_mismatch(k, case, mine.len(), reference.len()) {
            return;
        }
        let row = &mut self.rows[k];
        row.count += mine.len();
        for (i, (&a, &r)) in mine.iter().zip(reference).enumerate() {
            let err = (a - r).abs();
            let al = allow(i, r);
            let rel_den = match rule {
                Rule::Rel { floor, .. } => r.abs().max(floor),
                Rule::Propagated(_) => r.abs(),
                _ => f64::NAN,
            };
            let ratio = if err.is_nan() {
                f64::INFINITY
            } else if al > 0.0 {
                err / al
            } else if err > 0.0 {
                f64::INFINITY
            } else {
                0.0
            };
            if err.is_nan() {
                row.max_abs = f64::NAN;
            } else if !row.max_abs.is_nan() {
                row.max_abs = row.max_abs.max(err);
            }
            if rel_den > 0.0 && !row.max_rel.is_nan() {
                row.max_rel = if err.is_nan() {
                    f64::NAN
                } else {
                    row.max_rel.max(err / rel_den)
                };
            }
            self.ref_max[k] = self.ref_max[k].max(r.abs());
            if ratio > 1.0 {
                row.passed = false;
            }
            if ratio > self.worst[k] && ratio > 0.0 {
                self.worst[k] = ratio;
                row.detail = format!("{case} {}", name(i)).trim().to_string();
            }
        }
        if let Rule::Abs(_) = rule {
            let m = self.ref_max[k];
            row.max_rel = if m > 0.0 { row.max_abs / m } else { 0.0 };
        }
    }

    /// Compares integers (booleans as 0/1) for equality.
    pub(crate) fn exact(
        &mut self,
        quantity: &str,
        case: &str,
        mine: &[i64],
        reference: &[i64],
        name: &dyn Fn(usize) -> String,
    ) {
        let k = self.slot(quantity, Rule::Exact);
        if self.length_mismatch(k, case, mine.len(), reference.len()) {
            return;
        }
        let row = &mut self.rows[k];
        row.count += mine.len();
        for (i, (&a, &r)) in mine.iter().zip(reference).enumerate() {
            if a != r {
                let d = (a - r).unsigned_abs() as f64;
                row.max_abs = row.max_abs.max(d);
                row.max_rel += 1.0;
                if row.passed {
                    row.detail = format!("{case} {}: {a}, file {r}", name(i));
                }
                row.passed = false;
            }
        }
        if !row.passed && row.max_rel > 1.0 {
            let first = row
                .detail
                .split(" (")
                .next()
                .unwrap_or_default()
                .to_string();
            row.detail = format!("{first} ({} mismatches)", row.max_rel);
        }
    }

    /// Fails row `k` if the computed and reference lengths differ.
    fn length_mismatch(&mut self, k: usize, case: &str, mine: usize, reference: usize) -> bool {
        if mine == reference {
            return false;
        }
        self.fail_at(
            k,
            format!("{case}: {mine} values computed, {reference} in the file"),
        );
        true
    }

    /// A quantity that could not be recomputed.
    pub(crate) fn fail(&mut self, quantity: &str, reason: &str) {
        let k = self.slot(quantity, Rule::NotComputed);
        self.fail_at(k, reason.to_string());
    }

    fn fail_at(&mut self, k: usize, reason: String) {
        let row = &mut self.rows[k];
        row.passed = false;
        self.worst[k] = f64::INFINITY;
        row.detail = reason;
    }

    /// The collected rows.
    pub(crate) fn into_rows(self) -> Vec<Row> {
        self.rows
    }
}

/// Entry names `[i]`, or `[i][j]` for rows of `width` entries.
pub(crate) fn index_name(width: usize) -> impl Fn(usize) -> String {
    move |i| {
        if width <= 1 {
            format!("[{i}]")
        } else {
            format!("[{}][{}]", i / width, i % width)
        }
    }
}

/// Entry names of a concatenation of named parts (e.g. `x_init`, `theta.W1`), each part
/// `(name, length, row width)`.
pub(crate) fn part_name(parts: Vec<(String, usize, usize)>) -> impl Fn(usize) -> String {
    move |mut i| {
        for (name, len, width) in &parts {
            if i < *len {
                return format!("{name}{}", index_name(*width)(i));
            }
            i -= len;
        }
        format!("[{i}]")
    }
}
