//! The neural field's VJP (positions and every parameter: planes, MLP weights, output
//! scales) against central differences in f64, the dot-product test, and bitwise agreement of
//! sequential and parallel evaluation.

use evogs::field::{FieldProfile, HexPlaneConfig, NeuralField, NeuralFieldConfig, TimeMapping};
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
    field_with(time, 3, false)
}

/// The small field with `channels` per plane (the channel loops work in blocks of 8 with a
/// scalar tail, so 3 covers the tail alone and 10 a block and a tail), its velocity read as a
/// twist or not.
fn field_with(time: TimeMapping, channels: usize, twist: bool) -> NeuralField<f64> {
    let cfg = NeuralFieldConfig {
        hexplane: HexPlaneConfig {
            channels,
            resolution: [4, 3, 5, 4],
            multires: vec![1, 2],
        },
        width: 8,
        output_scales: [10.0, 1.0, 1.0],
        zero_init_output: false,
        twist,
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
    for time in [UNIT_TIME, TimeMapping::Raw] {
        check_vjp_against_central_differences(&mut small_field(time), 5, &format!("{time:?}"));
    }
}

#[test]
fn vjp_matches_central_differences_across_a_channel_block_and_its_tail() {
    // 10 channels: one 8-channel block of the vectorised loops and a scalar tail of 2.
    let time = UNIT_TIME;
    check_vjp_against_central_differences(&mut field_with(time, 10, false), 5, "10 channels");
}

#[test]
fn twist_velocity_vjp_matches_central_differences() {
    // v = a + ω × (x − c): the position gradient gains w × ω, the angular-velocity head (and
    // its output scale) gains (x − c) × w.
    let time = UNIT_TIME;
    check_vjp_against_central_differences(&mut field_with(time, 3, true), 5, "twist");
}

#[test]
fn twist_velocity_is_the_heads_plus_omega_cross_the_arm() {
    let time = TimeMapping::Raw;
    let (mut plain, mut twist) = (field_with(time, 3, false), field_with(time, 3, true));
    let n = 4;
    let y = states(n, 13);
    plain.set_count(n);
    twist.set_count(n);
    let (mut a, mut b) = (vec![0.0; 9 * n], vec![0.0; 9 * n]);
    plain.eval(0.3, &y, &mut a);
    twist.eval(0.3, &y, &mut b);
    // The box is [-1, 1] × [-1.5, 1] × [-0.5, 1.5]: centre (0, -0.25, 0.5).
    let c = [0.0, -0.25, 0.5];
    for i in 0..n {
        let (o, p) = (&a[9 * i..9 * i + 9], &y[10 * i..10 * i + 3]);
        let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        let cross = [
            o[4] * r[2] - o[5] * r[1],
            o[5] * r[0] - o[3] * r[2],
            o[3] * r[1] - o[4] * r[0],
        ];
        for k in 0..9 {
            let want = if k < 3 { o[k] + cross[k] } else { o[k] };
            assert!(
                (b[9 * i + k] - want).abs() < 1e-14,
                "Gaussian {i} output {k}"
            );
        }
    }
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
    let mut f = field_with(time, 10, false);
    f.set_count(n);
    let mut d_y = vec![0.0; n * 9];
    let mut d_p = vec![0.0; f.n_params()];
    f.vjp(0.42, &y, &w, &mut d_y, &mut d_p);
    let mut g = field_with(time, 10, false);
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

#[test]
fn stored_evaluations_give_bitwise_identical_outputs_and_vjps() {
    let n = 600; // several chunks
    let y = states(n, 29);
    let mut rng = SplitMix64::new(31);
    let w: Vec<f64> = (0..n * 9).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let run_with = |capacity: usize, budget: usize, interleave: bool| {
        let mut f = small_field(UNIT_TIME);
        f.set_count(n);
        f.set_eval_capacity(capacity);
        f.set_eval_budget(budget);
        let profile = Arc::new(FieldProfile::default());
        f.set_profile(Some(Arc::clone(&profile)));
        let mut outs = Vec::new();
        let mut grads = Vec::new();
        // Evaluate at three times, then take the VJPs in reverse (as the discrete adjoint does),
        // with a parameter change in between when `interleave` (which must invalidate).
        for &t in &[0.1, 0.4, 0.7] {
            let mut out = vec![0.0; n * 9];
            f.eval(t, &y, &mut out);
            outs.push(out);
        }
        if interleave {
            let v = f.params()[3];
            f.params_mut()[3] = v; // same value, but a mutable access invalidates
        }
        for &t in &[0.7, 0.4, 0.1] {
            let mut out = vec![0.0; n * 9];
            f.eval(t, &y, &mut out); // a repeated evaluation: served from storage when possible
            outs.push(out);
            let mut d_y = vec![0.0; n * 9];
            let mut d_p = vec![0.0; f.n_params()];
            f.vjp(t, &y, &w, &mut d_y, &mut d_p);
            grads.push((d_y, d_p));
        }
        (outs, grads, profile.take().forward_rows)
    };
    let run = |capacity: usize, interleave: bool| {
        let (outs, grads, _) = run_with(capacity, usize::MAX, interleave);
        (outs, grads)
    };
    let plain = run(1, false);
    assert!(
        run(3, false) == plain,
        "reusing stored evaluations changes nothing"
    );
    assert!(
        run(3, true) == plain,
        "parameter changes invalidate stored evaluations"
    );
    assert!(run(2, false) == plain, "evictions are handled");
    // The memory budget: room for two evaluations of n Gaussians keeps two whatever the
    // capacity, and a budget below one evaluation keeps one; results never change.
    let (outs3, grads3, fresh3) = run_with(3, usize::MAX, false);
    let (outs_b, grads_b, fresh_b) =
        run_with(3, 2 * small_field(UNIT_TIME).evaluation_bytes(n), false);
    let (outs_0, grads_0, fresh_0) = run_with(3, 0, false);
    assert!(outs_b == outs3 && grads_b == grads3 && outs_0 == outs3 && grads_0 == grads3);
    let (_, _, fresh2) = run_with(2, usize::MAX, false);
    let (_, _, fresh1) = run_with(1, usize::MAX, false);
    assert_eq!(fresh_b, fresh2, "a budget of two evaluations keeps two");
    assert_eq!(fresh_0, fresh1, "a budget below one evaluation keeps one");
    assert!(
        fresh3 < fresh2 && fresh2 < fresh1,
        "{fresh3} {fresh2} {fresh1}"
    );
}
