//! Parity with the ODE reference vectors (`tests/data/oracle/ode_shared_*.json`, computed
//! with torchdiffeq 0.2.5 and scipy in float64; conventions in SCHEMA.md there).
//!
//! For every run (forward and backward in time), method and N: `x_final` and
//! `grad_discrete` to 1e-10 and both continuous-adjoint variants to 1e-9, relative to
//! `max(1, |ref|)`.

use evogs_ode::fields::{LinearField, Mlp};
use evogs_ode::{
    Checkpointing, ContinuousVariant, Method, Stepper, TimeGrid, VectorField, continuous_adjoint,
    discrete_adjoint, integrate_trajectory,
};
use serde_json::Value;

fn load(name: &str) -> Value {
    let path = format!("{}/../tests/data/oracle/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).expect("valid JSON")
}

fn flatten(v: &Value, out: &mut Vec<f64>) {
    match v {
        Value::Array(a) => a.iter().for_each(|x| flatten(x, out)),
        Value::Number(n) => out.push(n.as_f64().expect("f64")),
        _ => panic!("unexpected JSON value {v}"),
    }
}

fn flat(v: &Value) -> Vec<f64> {
    let mut out = Vec::new();
    flatten(v, &mut out);
    out
}

/// θ of the case in the field's parameter order.
fn theta_of(obj: &Value, keys: &[&str]) -> Vec<f64> {
    keys.iter().flat_map(|k| flat(&obj[*k])).collect()
}

/// Worst `|a − r|/max(1, |r|)`.
fn worst(a: &[f64], r: &[f64]) -> f64 {
    assert_eq!(a.len(), r.len(), "compared lengths");
    a.iter()
        .zip(r)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1.0))
        .fold(0.0, f64::max)
}

#[derive(Default, Debug)]
struct Worst {
    x_final: f64,
    discrete: f64,
    discrete_every: f64,
    reintegrate: f64,
    checkpoint: f64,
}

fn run_file<F: VectorField<f64>>(file: &str, keys: &[&str], make: impl Fn(&[f64]) -> F) -> Worst {
    let d = load(file);
    let case = &d["case"];
    let theta = if keys == ["A"] {
        flat(&case["A"])
    } else {
        theta_of(&case["theta"], keys)
    };
    let x0 = flat(&case["x_init"]);
    let c = flat(&case["c"]);
    let mut w = Worst::default();
    let mut n_results = 0;
    for run in case["runs"].as_array().expect("runs") {
        let (t0, t1) = (run["t0"].as_f64().unwrap(), run["t1"].as_f64().unwrap());
        for res in run["results"].as_array().expect("results") {
            let method: Method = res["method"].as_str().unwrap().parse().expect("method");
            let n = usize::try_from(res["n_steps"].as_u64().unwrap()).unwrap();
            let grid = TimeGrid::uniform(t0, t1, n);
            let mut field = make(&theta);
            let mut st = Stepper::new(method, field.layout());
            let what = format!("{file} {} {method} N={n}", run["direction"]);
            // Forward solution.
            let traj =
                integrate_trajectory(&mut field, &mut st, &grid, &x0, Checkpointing::StoreAll);
            let e = worst(traj.final_state(), &flat(&res["x_final"]));
            assert!(e < 1e-10, "{what}: x_final off by {e:e}");
            w.x_final = w.x_final.max(e);
            // Discrete adjoint, store-all and √N checkpointing.
            let gd = &res["grad_discrete"];
            let mut ref_g = flat(&gd["x_init"]);
            ref_g.extend(theta_of(&gd["theta"], keys));
            let mut d_y0 = vec![0.0; 3];
            let mut d_th = vec![0.0; theta.len()];
            discrete_adjoint(&mut field, &mut st, &traj, &c, &mut d_y0, &mut d_th);
            let mut g = d_y0.clone();
            g.extend(&d_th);
            let e = worst(&g, &ref_g);
            assert!(e < 1e-10, "{what}: grad_discrete off by {e:e}");
            w.discrete = w.discrete.max(e);
            let traj2 =
                integrate_trajectory(&mut field, &mut st, &grid, &x0, Checkpointing::sqrt(n));
            let (mut d_y0b, mut d_thb) = (vec![0.0; 3], vec![0.0; theta.len()]);
            discrete_adjoint(&mut field, &mut st, &traj2, &c, &mut d_y0b, &mut d_thb);
            assert!(
                d_y0b == d_y0 && d_thb == d_th,
                "{what}: √N checkpointing not bitwise equal"
            );
            w.discrete_every = w.discrete_every.max(worst(&d_y0b, &ref_g[..3]));
            // Continuous adjoints.
            for (variant, key) in [
                (ContinuousVariant::Reintegrate, "grad_adjoint_reintegrate"),
                (ContinuousVariant::Checkpoint, "grad_adjoint_checkpoint"),
            ] {
                let r = continuous_adjoint(&mut field, method, &grid, &x0, &c, variant)
                    .expect("Euclidean field");
                let mut g = r.d_y0.clone();
                g.extend(&r.d_params);
                let mut want = flat(&res[key]["x_init"]);
                want.extend(theta_of(&res[key]["theta"], keys));
                let e = worst(&g, &want);
                assert!(e < 1e-9, "{what}: {key} off by {e:e}");
                match variant {
                    ContinuousVariant::Reintegrate => {
                        w.reintegrate = w.reintegrate.max(e);
                        assert!(
                            r.reconstruction_error.is_some(),
                            "reintegrate reports x(t0)"
                        );
                    }
                    ContinuousVariant::Checkpoint => w.checkpoint = w.checkpoint.max(e),
                }
            }
            n_results += 1;
        }
    }
    assert!(n_results >= 48, "{file}: only {n_results} results checked");
    println!("{file}: {n_results} results, worst errors {w:?}");
    w
}

const MLP_KEYS: [&str; 6] = ["W1", "b1", "W2", "b2", "W3", "b3"];

#[test]
fn mlp_reference_vectors() {
    run_file("ode_shared_mlp_seed0.json", &MLP_KEYS, |th| {
        Mlp::new(3, 16, th.to_vec())
    });
}

#[test]
fn linear_reference_vectors() {
    run_file("ode_shared_linear_seed0.json", &["A"], |th| {
        LinearField::new(3, th.to_vec())
    });
}

/// The MLP reference solution (DOP853, rtol = atol = 1e-13) and the N = 2048 RK4 gradient:
/// our RK4 converges to both.
#[test]
fn mlp_converges_to_the_reference_solution() {
    let d = load("ode_shared_mlp_seed0.json");
    let case = &d["case"];
    let theta = theta_of(&case["theta"], &MLP_KEYS);
    let x0 = flat(&case["x_init"]);
    let c = flat(&case["c"]);
    for run in case["runs"].as_array().unwrap() {
        let (t0, t1) = (run["t0"].as_f64().unwrap(), run["t1"].as_f64().unwrap());
        let reference = &run["reference"];
        let mut field = Mlp::new(3, 16, theta.clone());
        let mut st = Stepper::new(Method::Rk4, field.layout());
        let grid = TimeGrid::uniform(t0, t1, 2048);
        let traj = integrate_trajectory(&mut field, &mut st, &grid, &x0, Checkpointing::sqrt(2048));
        let e = worst(traj.final_state(), &flat(&reference["x_final"]));
        assert!(e < 1e-12, "x_final vs DOP853: {e:e}");
        let mut d_y0 = vec![0.0; 3];
        let mut d_th = vec![0.0; theta.len()];
        discrete_adjoint(&mut field, &mut st, &traj, &c, &mut d_y0, &mut d_th);
        let mut g = d_y0;
        g.extend(&d_th);
        let mut want = flat(&reference["grad"]["x_init"]);
        want.extend(theta_of(&reference["grad"]["theta"], &MLP_KEYS));
        let e = worst(&g, &want);
        assert!(e < 1e-12, "N = 2048 gradient vs reference: {e:e}");
        println!(
            "{} reference: x_final and gradient within {e:e}",
            run["direction"]
        );
    }
}

/// The linear file's exact values: the RK4 error and the observed orders it lists.
#[test]
fn linear_exact_values_and_listed_errors() {
    let d = load("ode_shared_linear_seed0.json");
    let case = &d["case"];
    let a = flat(&case["A"]);
    let x0 = flat(&case["x_init"]);
    for run in case["runs"].as_array().unwrap() {
        let (t0, t1) = (run["t0"].as_f64().unwrap(), run["t1"].as_f64().unwrap());
        let exact = flat(&run["exact"]["x_final"]);
        for res in run["results"].as_array().unwrap() {
            let method: Method = res["method"].as_str().unwrap().parse().unwrap();
            let n = usize::try_from(res["n_steps"].as_u64().unwrap()).unwrap();
            let mut field = LinearField::new(3, a.clone());
            let mut st = Stepper::new(method, field.layout());
            let mut y = x0.clone();
            evogs_ode::integrate(&mut field, &mut st, &TimeGrid::uniform(t0, t1, n), &mut y);
            let err = y
                .iter()
                .zip(&exact)
                .map(|(p, q)| (p - q).powi(2))
                .sum::<f64>()
                .sqrt();
            let listed = res["error_l2"].as_f64().unwrap();
            // x_final agrees to ~1e-16, so the error values agree in absolute terms.
            assert!(
                (err - listed).abs() <= 1e-13,
                "{method} N={n}: error {err:e} vs listed {listed:e}"
            );
        }
    }
}
