//! The neural field's VJP (positions and every parameter: planes, MLP weights, output
//! scales) against central differences in f64, the dot-product test, bitwise agreement of
//! sequential and parallel evaluation, and of the VJP from a forward record with the one that
//! recomputes the forward pass (also through the ODE adjoint's stage tape under a memory
//! budget).

use evogs::field::{
    Batch, BatchVjp, FieldProfile, FieldRecord, HexPlaneConfig, NeuralField, NeuralFieldConfig,
    TimeMapping,
};
use evogs_math::Par;
use evogs_math::diff::{GradCheck, central_gradient, central_jvp, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_ode::VectorField;
use std::sync::Arc;

/// Training times normalised over [0, 1].
const UNIT_TIME: TimeMapping = TimeMapping::Normalized {
    t_min: 0.0,
    t_max: 1.0,
};

fn small_field(time: TimeMapping) -> NeuralField<f64> {
    field_with(time, 3)
}

/// The small field with `channels` per plane (the channel loops work in blocks of 8 with a
/// scalar tail, so 3 covers the tail alone and 10 a block and a tail).
fn field_with(time: TimeMapping, channels: usize) -> NeuralField<f64> {
    let cfg = NeuralFieldConfig {
        hexplane: HexPlaneConfig {
            channels,
            resolution: [4, 3, 5, 4],
            multires: vec![1, 2],
        },
        width: 8,
        output_scales: [10.0, 1.0, 1.0],
        zero_init_output: false,
    };
    let mut f = NeuralField::new(&cfg, [-1.0, -1.5, -0.5], [1.0, 1.0, 1.5], time, 7);
    // Perturb the time planes away from 1 so that time actually matters.
    let mut rng = SplitMix64::new(11);
    for v in f.params_mut().iter_mut() {
        *v += rng.uniform(-0.2, 0.2);
    }
    f
}

/// Gaussian states `[p (3), q (4), s (3)]` with positions strictly inside the box.
fn states(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    let mut y = Vec::with_capacity(n * 10);
    for _ in 0..n {
        y.extend([
            rng.uniform(-0.9, 0.9),
            rng.uniform(-1.4, 0.9),
            rng.uniform(-0.4, 1.4),
        ]);
        y.extend([1.0, 0.0, 0.0, 0.0]);
        y.extend([-3.0, -3.0, -3.0]);
    }
    y
}

/// Checks the VJP of `f` over `n` Gaussians against central differences of
/// `L = <w, f(y)>`: positions (with zero rotation and scale parts) and every parameter.
fn check_vjp_against_central_differences(f: &mut NeuralField<f64>, n: usize, label: &str) {
    f.set_count(n);
    let y = states(n, 3);
    let t = 0.37;
    let mut rng = SplitMix64::new(5);
    let w: Vec<f64> = (0..n * 9).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let mut d_y = vec![0.0; n * 9];
    let mut d_p = vec![0.0; f.n_params()];
    f.vjp(t, &y, &w, &mut d_y, &mut d_p);
    // Positions: L = <w, f(y)>.
    let mut num = vec![0.0; y.len()];
    let mut yy = y.clone();
    let mut out = vec![0.0; n * 9];
    central_gradient(
        |v: &[f64]| {
            f.eval(t, v, &mut out);
            out.iter().zip(&w).map(|(a, b)| a * b).sum()
        },
        &mut yy,
        &mut num,
    );
    let analytic: Vec<f64> = (0..n)
        .flat_map(|i| d_y[i * 9..i * 9 + 3].to_vec())
        .collect();
    let numeric: Vec<f64> = (0..n)
        .flat_map(|i| num[i * 10..i * 10 + 3].to_vec())
        .collect();
    GradCheck::new(1e-8, 1e-6)
        .check(&analytic, &numeric)
        .assert_passed("d position");
    for i in 0..n {
        assert!(
            d_y[i * 9 + 3..i * 9 + 9].iter().all(|&v| v == 0.0),
            "no rotation or scale dependence"
        );
        assert!(
            num[i * 10 + 3..i * 10 + 10]
                .iter()
                .all(|&v| v.abs() < 1e-12),
            "numerically too"
        );
    }
    // Every parameter (the field is small enough).
    let p0 = f.params().to_vec();
    let mut num = vec![0.0; p0.len()];
    let mut pp = p0.clone();
    central_gradient(
        |v: &[f64]| {
            f.params_mut().copy_from_slice(v);
            f.eval(t, &y, &mut out);
            out.iter().zip(&w).map(|(a, b)| a * b).sum()
        },
        &mut pp,
        &mut num,
    );
    f.params_mut().copy_from_slice(&p0);
    let rep = GradCheck::new(1e-8, 1e-6).check(&d_p, &num);
    rep.assert_passed("d parameters");
    println!(
        "neural field {label}: {n} Gaussians, positions and {} parameters, {rep}",
        p0.len()
    );
}

#[test]
fn vjp_matches_central_differences_for_positions_and_parameters() {
    // The unit range, and a range the times fall partly outside of.
    let other = TimeMapping::Normalized {
        t_min: 0.25,
        t_max: 0.5,
    };
    for time in [UNIT_TIME, other] {
        check_vjp_against_central_differences(&mut small_field(time), 5, &format!("{time:?}"));
    }
}

#[test]
fn vjp_matches_central_differences_across_a_channel_block_and_its_tail() {
    // 10 channels: one 8-channel block of the vectorised loops and a scalar tail of 2.
    check_vjp_against_central_differences(&mut field_with(UNIT_TIME, 10), 5, "10 channels");
}

#[test]
fn batched_vjp_over_several_chunks_is_the_sum_of_single_gaussian_vjps() {
    // A full work chunk and a partial one (the plane scatter reads each chunk's records
    // plane-major): the batched VJP must equal the Gaussian-by-Gaussian VJPs, summed over
    // Gaussians for the parameters. (Central differences over this many Gaussians would sit
    // on ReLU and cell kinks; the single-Gaussian VJP is checked against them above.)
    let time = UNIT_TIME;
    let n = evogs::field::CHUNK + 37;
    let y = states(n, 13);
    let mut rng = SplitMix64::new(17);
    let w: Vec<f64> = (0..n * 9).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let mut f = field_with(time, 10);
    f.set_count(n);
    let mut d_y = vec![0.0; n * 9];
    let mut d_p = vec![0.0; f.n_params()];
    f.vjp(0.42, &y, &w, &mut d_y, &mut d_p);
    let mut g = field_with(time, 10);
    g.set_count(1);
    let mut sum_p = vec![0.0; g.n_params()];
    for i in 0..n {
        let mut d_yi = vec![0.0; 9];
        g.vjp(
            0.42,
            &y[i * 10..(i + 1) * 10],
            &w[i * 9..(i + 1) * 9],
            &mut d_yi,
            &mut sum_p,
        );
        GradCheck::new(1e-13, 1e-11)
            .check(&d_y[i * 9..(i + 1) * 9], &d_yi)
            .assert_passed("d position of one Gaussian");
    }
    let rep = GradCheck::new(1e-12, 1e-10).check(&d_p, &sum_p);
    rep.assert_passed("d parameters summed over Gaussians");
    println!("{n} Gaussians in two chunks: {rep}");
}

#[test]
fn vjp_passes_the_dot_product_test() {
    let mut f = small_field(UNIT_TIME);
    let n = 7;
    f.set_count(n);
    let y = states(n, 9);
    let np = f.n_params();
    let p0 = f.params().to_vec();
    // Inputs: all positions (3n) and all parameters; outputs: 9n.
    let pos: Vec<f64> = (0..n)
        .flat_map(|i| y[i * 10..i * 10 + 3].to_vec())
        .collect();
    let mut x0 = pos.clone();
    x0.extend(&p0);
    let eval = |f: &mut NeuralField<f64>, x: &[f64], out: &mut [f64]| {
        let mut yy = y.clone();
        for i in 0..n {
            yy[i * 10..i * 10 + 3].copy_from_slice(&x[i * 3..i * 3 + 3]);
        }
        f.params_mut().copy_from_slice(&x[3 * n..]);
        f.eval(0.6, &yy, out);
    };
    let r = vjp_dot_test(
        |v: &[f64], out: &mut [f64]| {
            central_jvp(|x: &[f64], o: &mut [f64]| eval(&mut f, x, o), &x0, v, out);
        },
        |w: &[f64], out: &mut [f64]| {
            let mut g = small_field(UNIT_TIME);
            g.params_mut().copy_from_slice(&p0);
            g.set_count(n);
            let mut d_y = vec![0.0; 9 * n];
            let mut d_p = vec![0.0; np];
            g.vjp(0.6, &y, w, &mut d_y, &mut d_p);
            for i in 0..n {
                out[i * 3..i * 3 + 3].copy_from_slice(&d_y[i * 9..i * 9 + 3]);
            }
            out[3 * n..].copy_from_slice(&d_p);
        },
        3 * n + np,
        9 * n,
        21,
    );
    assert!(r < 1e-8, "dot-product test residual {r}");
}

#[cfg(feature = "rayon")]
#[test]
fn parallel_evaluation_is_bitwise_sequential() {
    let mut f = small_field(UNIT_TIME);
    let n = 1000; // several chunks
    f.set_count(n);
    let y = states(n, 13);
    let mut rng = SplitMix64::new(17);
    let w: Vec<f64> = (0..n * 9).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let mut results = Vec::new();
    for par in [Par::Seq, Par::Rayon] {
        f.set_par(par);
        let mut out = vec![0.0; n * 9];
        f.eval(0.2, &y, &mut out);
        let mut d_y = vec![0.0; n * 9];
        let mut d_p = vec![0.0; f.n_params()];
        f.vjp(0.2, &y, &w, &mut d_y, &mut d_p);
        results.push((out, d_y, d_p));
    }
    assert!(results[0] == results[1], "Seq and Rayon differ");
}

/// The outputs and the VJPs (position and parameter gradients for the cotangent `w`) of
/// the small field at `n` positions and three times, the VJPs from the evaluations' records
/// (`recorded`) or recomputing; and the MLP rows run forward.
/// The outputs per time, the (position, parameter) gradients per VJP and the MLP rows run
/// forward.
type Calls = (Vec<Vec<f64>>, Vec<(Vec<f64>, Vec<f64>)>, u64);

fn outputs_and_vjps(n: usize, recorded: bool) -> Calls {
    let y = states(n, 29);
    let mut rng = SplitMix64::new(31);
    let w: Vec<f64> = (0..n * 9).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let mut f = small_field(UNIT_TIME);
    let profile = Arc::new(FieldProfile::default());
    f.set_profile(Some(Arc::clone(&profile)));
    let times = [0.1, 0.4, 0.7];
    let mut records: Vec<FieldRecord<f64>> = times.iter().map(|_| FieldRecord::default()).collect();
    let mut outs = Vec::new();
    for (&t, rec) in times.iter().zip(&mut records) {
        let at = Batch {
            t,
            positions: &y,
            stride: 10,
            n,
        };
        let mut out = vec![0.0; n * 9];
        f.eval_batch(&at, &mut out, recorded.then_some(rec));
        outs.push(out);
    }
    // The VJPs in reverse, as the discrete adjoint takes them.
    let mut grads = Vec::new();
    for (&t, rec) in times.iter().zip(&records).rev() {
        let mut d_y = vec![0.0; n * 9];
        let mut d_p = vec![0.0; f.n_params()];
        f.vjp_batch(BatchVjp {
            at: Batch {
                t,
                positions: &y,
                stride: 10,
                n,
            },
            record: recorded.then_some(rec),
            d_out: &w,
            d_positions: &mut d_y,
            d_stride: 9,
            d_params: &mut d_p,
        });
        grads.push((d_y, d_p));
    }
    (outs, grads, profile.take().forward_rows)
}

#[test]
fn vjps_from_records_are_bitwise_the_recomputed_ones() {
    let n = 600; // several chunks
    let (outs, grads, fresh) = outputs_and_vjps(n, true);
    let (outs_r, grads_r, fresh_r) = outputs_and_vjps(n, false);
    assert!(outs == outs_r && grads == grads_r, "records change nothing");
    assert_eq!(
        fresh,
        3 * 600,
        "with records only the evaluations run forward"
    );
    assert_eq!(
        fresh_r,
        6 * 600,
        "without, every VJP runs the forward pass again"
    );
}

#[test]
#[should_panic(expected = "not written by this evaluation")]
fn a_record_of_another_time_is_refused() {
    let n = 3;
    let y = states(n, 5);
    let mut f = small_field(UNIT_TIME);
    let mut rec = FieldRecord::default();
    let at = |t| Batch {
        t,
        positions: &y,
        stride: 10,
        n,
    };
    let mut out = vec![0.0; n * 9];
    f.eval_batch(&at(0.1), &mut out, Some(&mut rec));
    let (mut d_y, mut d_p) = (vec![0.0; n * 9], vec![0.0; f.n_params()]);
    f.vjp_batch(BatchVjp {
        at: at(0.4),
        record: Some(&rec),
        d_out: &out,
        d_positions: &mut d_y,
        d_stride: 9,
        d_params: &mut d_p,
    });
}

#[test]
#[should_panic(expected = "parameters changed")]
fn a_record_of_older_parameters_is_refused() {
    let n = 3;
    let y = states(n, 5);
    let mut f = small_field(UNIT_TIME);
    f.set_count(n);
    let mut rec = FieldRecord::default();
    let mut out = vec![0.0; n * 9];
    f.eval_recorded(0.2, &y, &mut out, &mut rec);
    let v = f.params()[3];
    f.params_mut()[3] = v; // the same value, but a mutable access is a parameter change
    let (mut d_y, mut d_p) = (vec![0.0; n * 9], vec![0.0; f.n_params()]);
    f.vjp_recorded(0.2, &y, &rec, &out, &mut d_y, &mut d_p);
}

#[test]
fn the_adjoint_from_a_stage_tape_is_bitwise_the_recomputing_one_within_any_budget() {
    use evogs_ode::{
        Checkpointing, Method, StageTape, Stepper, TimeGrid, discrete_adjoint,
        discrete_adjoint_recorded, integrate_recorded, integrate_trajectory,
    };
    let n = 300; // two chunks
    let y0 = states(n, 41);
    let mut rng = SplitMix64::new(43);
    let d_final: Vec<f64> = (0..n * 9).map(|_| 0.1 * rng.uniform(-1.0, 1.0)).collect();
    // Three midpoint steps: six stage evaluations.
    let grid = TimeGrid::uniform(0.1, 0.7, 3);
    let one = small_field(UNIT_TIME).evaluation_bytes(n);
    let run = |budget: Option<usize>| {
        let mut f = small_field(UNIT_TIME);
        f.set_count(n);
        let profile = Arc::new(FieldProfile::default());
        f.set_profile(Some(Arc::clone(&profile)));
        let mut st = Stepper::new(Method::Midpoint, f.layout());
        let (mut d_y0, mut d_p) = (vec![0.0; n * 9], vec![0.0; f.n_params()]);
        let (end, kept) = if let Some(bytes) = budget {
            f.set_eval_budget(bytes);
            let mut tape = StageTape::new(f.records_within_budget(n));
            let traj = integrate_recorded(&mut f, &mut st, &grid, &y0, &mut tape);
            let mut tape_d = (d_y0.clone(), d_p.clone());
            discrete_adjoint_recorded(
                &mut f,
                &mut st,
                &traj,
                &mut tape,
                &d_final,
                &mut tape_d.0,
                &mut tape_d.1,
            );
            (d_y0, d_p) = tape_d;
            (traj.final_state().to_vec(), tape.kept_stages())
        } else {
            let traj = integrate_trajectory(&mut f, &mut st, &grid, &y0, Checkpointing::StoreAll);
            discrete_adjoint(&mut f, &mut st, &traj, &d_final, &mut d_y0, &mut d_p);
            (traj.final_state().to_vec(), 0)
        };
        let rows = profile.take().forward_rows;
        ((end, d_y0, d_p), kept, rows)
    };
    let (plain, _, plain_rows) = run(None);
    assert_eq!(
        plain_rows,
        6 * 3 * 300,
        "each stage forward, again in the reverse pass, and again in its VJP"
    );
    for (budget, want_kept) in [
        (usize::MAX, 6),
        (5 * one, 4),
        (2 * one, 2),
        (one, 0),
        (0, 0),
    ] {
        let (got, kept, rows) = run(Some(budget));
        assert!(
            got == plain,
            "budget {budget}: the same trajectory and gradients"
        );
        assert_eq!(
            kept,
            want_kept,
            "budget of {} evaluations: whole steps",
            budget / one
        );
        // Kept stages run forward once; the others once more in the reverse pass (into a
        // scratch record that their VJPs read).
        assert_eq!(rows, ((6 + (6 - kept)) * n) as u64, "budget {budget}");
    }
}
