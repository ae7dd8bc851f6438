//! `ode_*` files: fixed-grid integration, the exact discrete adjoint and both continuous
//! adjoints against torchdiffeq 0.2.5 and scipy (SCHEMA.md, "ode"), for both directions,
//! every method and every N, with the file's field (`mlp` → [`Mlp`], `linear` →
//! [`LinearField`]).
//!
//! Tolerances (relative to `max(1, |r|)`): `x_final`, `grad_discrete`, the exact solution
//! of linear files and the MLP reference 1e-10; the continuous adjoints 1e-9.
//!
//! Linear files also list `error_l2 = |x_final − exact|₂`,
//! `grad_error_x_init_discrete = |grad_discrete.x_init − exact.grad_x_init|₂` (both
//! recomputed from our values: 1e-10·max(1, |r|), the tolerance of what they are made of)
//! and `observed_order_vs_next = log(e_N/e_N')/log(N'/N)` over the next listed N' of the same
//! method. The errors are only defined to the rounding of the solutions, δ = 1e-14
//! absolute (≈ 50 ε for states of norm ~1 after ≤ 256 steps), so the order is compared with
//! the propagated allowance `(δ/e_N + δ/e_N')/ln(N'/N)` (≈ 4e-3 at e ≈ 4e-12).

use super::expm::{expm, expm_frechet};
use super::json::{ANY, Node, Res};
use super::report::{Row, Rule, Tally, part_name};
use evogs_ode::fields::{LinearField, Mlp};
use evogs_ode::{
    Checkpointing, ContinuousVariant, Method, Stepper, TimeGrid, VectorField, continuous_adjoint,
    discrete_adjoint, integrate_trajectory,
};

const DISCRETE: Rule = Rule::Rel {
    tol: 1e-10,
    floor: 1.0,
};
const CONTINUOUS: Rule = Rule::Rel {
    tol: 1e-9,
    floor: 1.0,
};
/// Absolute precision of an integration error (see the module docs).
const ERROR_DELTA: f64 = 1e-14;
/// Steps of the RK4 solution compared with the MLP reference (as the file's gradient).
const REFERENCE_STEPS: usize = 2048;

/// The MLP parameter arrays, in θ order.
const MLP_KEYS: [&str; 6] = ["W1", "b1", "W2", "b2", "W3", "b3"];

/// The field of a file.
enum Field {
    Mlp { n: usize, h: usize, theta: Vec<f64> },
    Linear { n: usize, a: Vec<f64> },
}

impl Field {
    fn dim(&self) -> usize {
        match self {
            Self::Mlp { n, .. } | Self::Linear { n, .. } => *n,
        }
    }

    /// Parameter arrays: (name, shape) in θ order.
    fn parts(&self) -> Vec<(String, Vec<usize>)> {
        match *self {
            Self::Mlp { n, h, .. } => vec![
                ("W1".into(), vec![h, n + 1]),
                ("b1".into(), vec![h]),
                ("W2".into(), vec![h, h]),
                ("b2".into(), vec![h]),
                ("W3".into(), vec![n, h]),
                ("b3".into(), vec![n]),
            ],
            Self::Linear { n, .. } => vec![("A".into(), vec![n, n])],
        }
    }

    /// Entry names of `[x_init, θ]`.
    fn names(&self) -> impl Fn(usize) -> String + use<> {
        let mut parts = vec![("x_init".to_string(), self.dim(), 1)];
        for (name, shape) in self.parts() {
            let len = shape.iter().product();
            let w = if shape.len() > 1 { shape[1] } else { 1 };
            parts.push((format!("theta.{name}"), len, w));
        }
        part_name(parts)
    }

    /// Reads a gradient object `{x_init, theta{…}}` as `[x_init, θ]`.
    fn read_grad(&self, g: &Node<'_>) -> Res<Vec<f64>> {
        let mut v = g.get("x_init")?.nums(&[self.dim()])?;
        let th = g.get("theta")?;
        for (name, shape) in self.parts() {
            v.extend(th.get(&name)?.nums(&shape)?);
        }
        Ok(v)
    }

    fn with<R>(&self, f: &mut dyn FnMut(&mut dyn VectorField<f64, Record = ()>) -> R) -> R {
        match self {
            Self::Mlp { n, h, theta } => f(&mut Mlp::new(*n, *h, theta.clone())),
            Self::Linear { n, a } => f(&mut LinearField::new(*n, a.clone())),
        }
    }
}

/// Our results for one (direction, method, N).
struct Solved {
    x_final: Vec<f64>,
    discrete: Vec<f64>,
    reintegrate: Vec<f64>,
    checkpoint: Vec<f64>,
}

fn solve(field: &Field, method: Method, grid: &TimeGrid<f64>, x0: &[f64], c: &[f64]) -> Solved {
    field.with(&mut |f| {
        let mut st = Stepper::new(method, f.layout());
        let traj = integrate_trajectory(f, &mut st, grid, x0, Checkpointing::StoreAll);
        let mut d_y0 = vec![0.0; f.dim()];
        let mut d_th = vec![0.0; f.n_params()];
        discrete_adjoint(f, &mut st, &traj, c, &mut d_y0, &mut d_th);
        let mut discrete = d_y0;
        discrete.extend(d_th);
        let mut cont = |variant| match continuous_adjoint(f, method, grid, x0, c, variant) {
            Ok(r) => {
                let mut g = r.d_y0;
                g.extend(r.d_params);
                g
            }
            Err(_) => Vec::new(),
        };
        let reintegrate = cont(ContinuousVariant::Reintegrate);
        let checkpoint = cont(ContinuousVariant::Checkpoint);
        Solved {
            x_final: traj.final_state().to_vec(),
            discrete,
            reintegrate,
            checkpoint,
        }
    })
}

fn read_field(case: &Node<'_>, t: &mut Tally) -> Res<Option<Field>> {
    let kind = case.get("field")?.str()?;
    let x0 = case.get("x_init")?.nums(&[ANY])?;
    let n = x0.len();
    Ok(match kind {
        "mlp" => {
            let th = case.get("theta")?;
            let h = th.get("b1")?.nums(&[ANY])?.len();
            let mut theta = Vec::new();
            for (key, shape) in MLP_KEYS.iter().zip([
                vec![h, n + 1],
                vec![h],
                vec![h, h],
                vec![h],
                vec![n, h],
                vec![n],
            ]) {
                theta.extend(th.get(key)?.nums(&shape)?);
            }
            Some(Field::Mlp { n, h, theta })
        }
        "linear" => Some(Field::Linear {
            n,
            a: case.get("A")?.nums(&[n, n])?,
        }),
        other => {
            t.fail(
                &format!("field \"{other}\""),
                "unknown ODE field (implemented: mlp, linear): nothing recomputed",
            );
            None
        }
    })
}

/// `|a − b|₂`.
fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// The exact solution of a linear file's run: `x_final`, `expm_A_T`, `grad_x_init`,
/// `grad_A`.
fn exact_linear(n: usize, a: &[f64], t_span: f64, x0: &[f64], c: &[f64]) -> [Vec<f64>; 4] {
    let at: Vec<f64> = a.iter().map(|v| v * t_span).collect();
    let e = expm(n, &at);
    let x: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| e[i * n + j] * x0[j]).sum())
        .collect();
    let gx: Vec<f64> = (0..n)
        .map(|j| (0..n).map(|i| e[i * n + j] * c[i]).sum())
        .collect();
    let mut ga = vec![0.0; n * n];
    for (ij, g) in ga.iter_mut().enumerate() {
        let mut dir = vec![0.0; n * n];
        dir[ij] = t_span;
        let l = expm_frechet(n, &at, &dir);
        *g = (0..n)
            .map(|i| c[i] * (0..n).map(|j| l[i * n + j] * x0[j]).sum::<f64>())
            .sum();
    }
    [x, e, gx, ga]
}

/// One run (direction) of a file.
fn run(t: &mut Tally, field: &Field, run: &Node<'_>, x0: &[f64], c: &[f64]) -> Res<usize> {
    let n = field.dim();
    let dir = run.get("direction")?.str()?.to_string();
    let (t0, t1) = (run.get("t0")?.f64()?, run.get("t1")?.f64()?);
    let names = field.names();
    let exact = match field {
        Field::Linear { a, .. } => {
            let ex = run.get("exact")?;
            let mine = exact_linear(n, a, t1 - t0, x0, c);
            for (key, shape, ours) in [
                ("x_final", vec![n], &mine[0]),
                ("expm_A_T", vec![n, n], &mine[1]),
                ("grad_x_init", vec![n], &mine[2]),
                ("grad_A", vec![n, n], &mine[3]),
            ] {
                let w = if shape.len() > 1 { n } else { 1 };
                t.floats(
                    &format!("exact.{key}"),
                    DISCRETE,
                    &dir,
                    ours,
                    &ex.get(key)?.nums(&shape)?,
                    &super::report::index_name(w),
                );
            }
            Some(mine)
        }
        Field::Mlp { .. } => None,
    };
    // Per method: (N, error_l2, listed order) for the order rows.
    let mut errors: Vec<(String, usize, f64, Option<f64>)> = Vec::new();
    let results = run.get("results")?.items()?;
    for res in &results {
        let mname = res.get("method")?.str()?;
        let n_steps = res.get("n_steps")?.usize()?;
        let Ok(method) = mname.parse::<Method>() else {
            t.fail(
                &format!("{mname} (all)"),
                &format!("method `{mname}` is not implemented: {dir} N={n_steps} not recomputed"),
            );
            continue;
        };
        let label = format!("{dir} N={n_steps}");
        let grid = TimeGrid::uniform(t0, t1, n_steps);
        let s = solve(field, method, &grid, x0, c);
        let q = |what: &str| format!("{mname} {what}");
        t.floats(
            &q("x_final"),
            DISCRETE,
            &label,
            &s.x_final,
            &res.get("x_final")?.nums(&[n])?,
            &super::report::index_name(1),
        );
        for (key, ours, rule) in [
            ("grad_discrete", &s.discrete, DISCRETE),
            ("grad_adjoint_reintegrate", &s.reintegrate, CONTINUOUS),
            ("grad_adjoint_checkpoint", &s.checkpoint, CONTINUOUS),
        ] {
            let reference = field.read_grad(&res.get(key)?)?;
            t.floats(&q(key), rule, &label, ours, &reference, &names);
        }
        if let Some(ex) = &exact {
            let e = dist(&s.x_final, &ex[0]);
            t.floats(
                &q("error_l2"),
                DISCRETE,
                &label,
                &[e],
                &[res.get("error_l2")?.f64()?],
                &|_| String::new(),
            );
            t.floats(
                &q("grad_error_x_init_discrete"),
                DISCRETE,
                &label,
                &[dist(&s.discrete[..n], &ex[2])],
                &[res.get("grad_error_x_init_discrete")?.f64()?],
                &|_| String::new(),
            );
            let listed = res.get("observed_order_vs_next")?;
            let listed = if listed.value().is_null() {
                None
            } else {
                Some(listed.f64()?)
            };
            errors.push((mname.to_string(), n_steps, e, listed));
        }
    }
    order_rows(t, &dir, &errors);
    Ok(results.len())
}

/// `observed_order_vs_next` of every (method, N) against our errors.
fn order_rows(t: &mut Tally, dir: &str, errors: &[(String, usize, f64, Option<f64>)]) {
    for (k, (m, n, e, listed)) in errors.iter().enumerate() {
        let next = errors.get(k + 1).filter(|x| x.0 == *m);
        let label = format!("{m} observed_order_vs_next");
        match (next, listed) {
            (None, None) => {}
            (Some((_, n2, e2, _)), Some(p)) => {
                let ln_ratio = (*n2 as f64 / *n as f64).ln();
                let mine = (e / e2).ln() / ln_ratio;
                let allow = (ERROR_DELTA / e + ERROR_DELTA / e2) / ln_ratio;
                t.floats_propagated(
                    &label,
                    ERROR_DELTA,
                    &format!("{dir} N={n}"),
                    &[mine],
                    &[*p],
                    &[allow],
                    &|_| String::new(),
                );
            }
            (None, Some(_)) => t.fail(&label, &format!("{dir} N={n}: listed, but no next N")),
            (Some(_), None) => t.fail(&label, &format!("{dir} N={n}: null, but a next N exists")),
        }
    }
}

/// The MLP file's `reference`: RK4 with N = 2048 against DOP853 (`x_final`) and against the
/// file's N = 2048 RK4 gradient.
fn reference_rows(t: &mut Tally, field: &Field, run: &Node<'_>, x0: &[f64], c: &[f64]) -> Res<()> {
    let dir = run.get("direction")?.str()?;
    let (t0, t1) = (run.get("t0")?.f64()?, run.get("t1")?.f64()?);
    let r = run.get("reference")?;
    let grid = TimeGrid::uniform(t0, t1, REFERENCE_STEPS);
    let (x, g) = field.with(&mut |f| {
        let mut st = Stepper::new(Method::Rk4, f.layout());
        let policy = Checkpointing::sqrt(REFERENCE_STEPS);
        let traj = integrate_trajectory(f, &mut st, &grid, x0, policy);
        let mut d_y0 = vec![0.0; f.dim()];
        let mut d_th = vec![0.0; f.n_params()];
        discrete_adjoint(f, &mut st, &traj, c, &mut d_y0, &mut d_th);
        d_y0.extend(d_th);
        (traj.final_state().to_vec(), d_y0)
    });
    t.floats(
        "reference.x_final (rk4 N=2048 vs DOP853)",
        DISCRETE,
        dir,
        &x,
        &r.get("x_final")?.nums(&[field.dim()])?,
        &super::report::index_name(1),
    );
    t.floats(
        "reference.grad (rk4 N=2048)",
        DISCRETE,
        dir,
        &g,
        &field.read_grad(&r.get("grad")?)?,
        &field.names(),
    );
    Ok(())
}

/// Recomputes an ODE file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let case = root.get("case")?;
    let mut t = Tally::default();
    let Some(field) = read_field(&case, &mut t)? else {
        return Ok((0, t.into_rows()));
    };
    let n = field.dim();
    let x0 = case.get("x_init")?.nums(&[n])?;
    let c = case.get("c")?.nums(&[n])?;
    let mut count = 0;
    for r in case.get("runs")?.items()? {
        count += run(&mut t, &field, &r, &x0, &c)?;
        if matches!(field, Field::Mlp { .. }) {
            reference_rows(&mut t, &field, &r, &x0, &c)?;
        }
    }
    Ok((count, t.into_rows()))
}
