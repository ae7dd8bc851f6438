//! `ode_adaptive_*` files: the adaptive pairs of [`evogs_ode::adaptive`] against scipy
//! DOP853 references (SCHEMA.md, `ode_adaptive_shared.json`), checked as the file's `check`
//! says, for every problem (built from its `name` and `params` by
//! [`evogs_ode::problems::by_name`], never from the file's numbers), both pairs (`dopri5`,
//! `bs32`) and tol ∈ {1e-4, 1e-6, 1e-8, 1e-10} with rtol = atol = tol:
//!
//! - `x(t)`: the states at `output_times` by dense output, entry by entry within
//!   `200·tol·max(1, |x_at|)` (stricter than the file's per-state norms);
//! - `∂x(t1)/∂x0` (tol ≤ 1e-6): the discrete adjoint's sensitivity matrix `S` (one adjoint
//!   per row), `‖S − ref‖_F / max(1, ‖ref‖_F) ≤ 1e3·tol` (the row's value is that ratio;
//!   the largest entrywise `|S − ref|/max(1, |ref|)` is in the note: on orbits such as
//!   Kepler's, where `S` has entries near 80, the discrete derivative's error on the
//!   entries near 0 and 1 exceeds 1e3·tol, see `tests/suite/adaptive_oracle.rs`).
//!
//! Every row's note gives our field evaluations beside scipy's RK45 at the same tolerance.

use super::json::{ANY, Node, Res};
use super::report::{Row, Rule, Tally, index_name};
use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair};
use evogs_ode::problems::by_name;

const TOLS: [f64; 4] = [1e-4, 1e-6, 1e-8, 1e-10];

/// A parameter's entries (a number or an array of numbers).
fn param(params: &Node<'_>, key: &str) -> Option<Vec<f64>> {
    let p = params.opt(key)?;
    p.f64().map(|v| vec![v]).or_else(|_| p.nums(&[ANY])).ok()
}

/// scipy's `(nfev, steps)` at `tol` (keys are Python's float reprs: matched by value).
fn scipy_at(scipy: &Node<'_>, tol: f64) -> Option<(usize, usize)> {
    let key = scipy.keys().into_iter().find(|k| {
        k.parse::<f64>()
            .is_ok_and(|v| (v - tol).abs() <= 1e-9 * tol)
    })?;
    let e = scipy.get(key).ok()?;
    Some((
        e.get("nfev").ok()?.usize().ok()?,
        e.get("steps").ok()?.usize().ok()?,
    ))
}

/// `‖a − r‖ / max(1, ‖r‖)` (Euclidean; Frobenius for matrices).
fn rel_norm(a: &[f64], r: &[f64]) -> f64 {
    let d = a
        .iter()
        .zip(r)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt();
    d / r.iter().map(|y| y * y).sum::<f64>().sqrt().max(1.0)
}

/// One problem of the file: every pair and tolerance.
fn problem(t: &mut Tally, p: &Node<'_>) -> Res<usize> {
    let name = p.get("name")?.str()?;
    let params = p.get("params")?;
    let mut field = match by_name(name, &|k: &str| param(&params, k)) {
        Ok(f) => f,
        Err(e) => {
            t.fail(
                &format!("{name} (all)"),
                &format!("{e}: nothing recomputed"),
            );
            return Ok(0);
        }
    };
    let (t0, t1) = (p.get("t0")?.f64()?, p.get("t1")?.f64()?);
    let n = field.dim();
    let x0 = p.get("x0")?.nums(&[n])?;
    let times = p.get("output_times")?.nums(&[ANY])?;
    let m = times.len();
    let x_at = p.get("x_at")?.nums(&[m, n])?;
    let sens = p.get("sensitivity_x1_wrt_x0")?.nums(&[n, n])?;
    let scipy = p.get("scipy_rk45")?;
    let mut count = 0;
    for pair in Pair::ALL {
        for tol in TOLS {
            let label = format!("{name} {pair} tol {tol:.0e}");
            let opts = AdaptiveOptions::with_tolerances(tol, tol);
            let mut solver = AdaptiveSolver::new(pair, field.layout(), opts);
            let sol = match solver.solve(&mut field, t0, t1, &x0, &times) {
                Ok(s) => s,
                Err(e) => {
                    t.fail(&format!("{label} x(t)"), &format!("solve failed: {e}"));
                    continue;
                }
            };
            let st = sol.stats();
            let nfev = match scipy_at(&scipy, tol) {
                Some((f, s)) => format!(
                    "nfev {} ({} steps), scipy RK45 {f} ({s})",
                    st.field_evals, st.accepted
                ),
                None => format!("nfev {} ({} steps), scipy: -", st.field_evals, st.accepted),
            };
            t.floats(
                &format!("{label} x(t)"),
                Rule::Rel {
                    tol: 200.0 * tol,
                    floor: 1.0,
                },
                &nfev,
                sol.outputs(),
                &x_at,
                &index_name(n),
            );
            count += 1;
            if tol > 1e-6 {
                continue;
            }
            let mut s_mat = vec![0.0; n * n];
            let mut failed = None;
            for i in 0..n {
                let mut d_out = vec![0.0; m * n];
                d_out[(m - 1) * n + i] = 1.0;
                let mut d_th = vec![0.0; field.n_params()];
                let mut d_t = vec![0.0; m];
                if let Err(e) = solver.adjoint(
                    &mut field,
                    &sol,
                    &d_out,
                    &mut s_mat[i * n..(i + 1) * n],
                    &mut d_th,
                    &mut d_t,
                ) {
                    failed = Some(e);
                }
            }
            let quantity = format!("{label} ∂x(t1)/∂x0 ‖S-r‖/max(1,‖r‖)");
            if let Some(e) = failed {
                t.fail(&quantity, &format!("adjoint failed: {e}"));
                continue;
            }
            let entrywise = s_mat
                .iter()
                .zip(&sens)
                .map(|(a, r)| (a - r).abs() / r.abs().max(1.0))
                .fold(0.0, f64::max);
            t.floats(
                &quantity,
                Rule::Abs(1e3 * tol),
                &format!("{nfev}; entrywise {entrywise:.1e}"),
                &[rel_norm(&s_mat, &sens)],
                &[0.0],
                &|_| String::new(),
            );
        }
    }
    Ok(count)
}

/// Recomputes an adaptive-ODE file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let mut t = Tally::default();
    let mut count = 0;
    for p in root.get("problems")?.items()? {
        count += problem(&mut t, &p)?;
    }
    Ok((count, t.into_rows()))
}
