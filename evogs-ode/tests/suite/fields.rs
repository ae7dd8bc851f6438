//! The example fields and the reference problems: VJPs against central differences and
//! dual numbers, and every closed-form solution against its own ODE.

use crate::common;

use common::{CoupledSe3Field, random_state, retract};
use evogs_math::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_math::so3::log_quat;
use evogs_math::{Dual, Quat, Se3, Vec3, Vec6};
use evogs_ode::fields::{LinearField, Mlp};
use evogs_ode::problems::{
    AsymmetricTop, ConstantRate, ConstantTwist, CosGrowth, DissipativePair, EulerRates,
    ExactProblem, ForcedOscillator, HarmonicOscillator, Kepler, Logistic, Lorenz, ProblemError,
    ProblemK, PropelledTop, RigidBody, RotatingDecay, ScrewPair, SymmetricTop, VanDerPol, by_name,
};
use evogs_ode::{Block, StateLayout, VectorField};

/// VJP of the field built from θ vs central differences of `w·f(t, y ⊕ δ; θ)` and vs the
/// dual-number JVP of the same generic field (dot-product test).
fn check<FF, FD>(
    what: &str,
    make: impl Fn(&[f64]) -> FF,
    make_d: impl Fn(&[Dual<f64>]) -> FD,
    theta: &[f64],
    y: &[f64],
) where
    FF: VectorField<f64>,
    FD: VectorField<Dual<f64>>,
{
    let mut f = make(theta);
    let layout = f.layout();
    let n = layout.tangent_len();
    let p = theta.len();
    assert_eq!(f.n_params(), p, "{what}: n_params");
    assert_eq!(f.dim(), n, "{what}: dim");
    let mut rng = SplitMix64::new(5);
    let w: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let t = 0.81;
    let mut analytic = vec![0.0; n + p];
    {
        let (dy, dth) = analytic.split_at_mut(n);
        f.vjp(t, y, &w, dy, dth);
    }
    let mut x = vec![0.0; n];
    x.extend_from_slice(theta);
    let mut numeric = vec![0.0; n + p];
    let mut out = vec![0.0; n];
    central_gradient(
        |v: &[f64]| {
            make(&v[n..]).eval(t, &retract(&layout, y, &v[..n]), &mut out);
            out.iter().zip(&w).map(|(a, b)| a * b).sum()
        },
        &mut x,
        &mut numeric,
    );
    GradCheck::new(1e-9, 1e-7)
        .check(&analytic, &numeric)
        .assert_passed(what);
    let r = vjp_dot_test(
        |v: &[f64], o: &mut [f64]| {
            dual_jvp(
                |xd: &[Dual<f64>], od: &mut [Dual<f64>]| {
                    let yd: Vec<Dual<f64>> = y.iter().map(|&a| Dual::constant(a)).collect();
                    make_d(&xd[n..]).eval(Dual::constant(t), &retract(&layout, &yd, &xd[..n]), od);
                },
                &x,
                v,
                o,
            );
        },
        |ww: &[f64], o: &mut [f64]| {
            o.fill(0.0);
            let (dy, dth) = o.split_at_mut(n);
            make(theta).vjp(t, y, ww, dy, dth);
        },
        n + p,
        n,
        8,
    );
    assert!(r < 1e-13, "{what}: dot-product residual {r:e}");
}

fn euclid(n: usize, seed: u64) -> Vec<f64> {
    random_state(&StateLayout::euclidean(n), seed)
}

#[test]
fn example_field_vjps() {
    let mut rng = SplitMix64::new(2);
    let a: Vec<f64> = (0..9).map(|_| rng.uniform(-1.0, 1.0)).collect();
    check(
        "linear field",
        |th| LinearField::new(3, th.to_vec()),
        |th| LinearField::new(3, th.to_vec()),
        &a,
        &euclid(3, 1),
    );
    let theta: Vec<f64> = (0..Mlp::<f64>::param_count(3, 16))
        .map(|_| rng.uniform(-0.7, 0.7))
        .collect();
    check(
        "mlp",
        |th| Mlp::new(3, 16, th.to_vec()),
        |th| Mlp::new(3, 16, th.to_vec()),
        &theta,
        &euclid(3, 2),
    );
    let proto = CoupledSe3Field::<f64>::random(2, 3);
    check(
        "coupled SE(3) test field",
        |th| CoupledSe3Field {
            theta: th.to_vec(),
            count: 2,
        },
        |th| CoupledSe3Field {
            theta: th.to_vec(),
            count: 2,
        },
        &proto.theta,
        &random_state(&proto.layout(), 4),
    );
}

#[test]
fn problem_field_vjps() {
    // Problem K's rate depends on time alone: no parameters, a zero VJP.
    check(
        "problem K",
        |_| ProblemK,
        |_| ProblemK,
        &[],
        &[0.6, 0.0, 0.8, 0.0],
    );
    check(
        "logistic",
        |th| Logistic {
            rate: th[0],
            ..Default::default()
        },
        |th| Logistic {
            rate: th[0],
            ..Default::default()
        },
        &[1.3],
        &[0.3],
    );
    check(
        "cos growth",
        |th| CosGrowth {
            k: th[0],
            ..Default::default()
        },
        |th| CosGrowth {
            k: th[0],
            ..Default::default()
        },
        &[0.8],
        &[1.4],
    );
    check(
        "harmonic oscillator",
        |th| HarmonicOscillator {
            omega: th[0],
            ..Default::default()
        },
        |th| HarmonicOscillator {
            omega: th[0],
            ..Default::default()
        },
        &[1.7],
        &[0.4, -0.9],
    );
    check(
        "rotating decay",
        |th| RotatingDecay {
            alpha: th[0],
            beta: th[1],
            ..Default::default()
        },
        |th| RotatingDecay {
            alpha: th[0],
            beta: th[1],
            ..Default::default()
        },
        &[-0.2, 1.5],
        &[0.4, -0.9],
    );
    check(
        "dissipative pair",
        |th| DissipativePair {
            theta: [th[0], th[1], th[2], th[3]],
        },
        |th| DissipativePair {
            theta: [th[0], th[1], th[2], th[3]],
        },
        &[1.0, 5.0, 2.0, 0.5],
        &[0.7, -0.2],
    );
    let so3 = StateLayout::particles(&[Block::So3], 1);
    check(
        "constant rate",
        |th| ConstantRate {
            omega: Vec3::from_slice(th),
            ..Default::default()
        },
        |th| ConstantRate {
            omega: Vec3::from_slice(th),
            ..Default::default()
        },
        &[0.3, -0.2, 0.9],
        &random_state(&so3, 3),
    );
    let body = StateLayout::particles(&[Block::So3, Block::Euclidean(3)], 1);
    check(
        "rigid body",
        |th| RigidBody {
            inertia: Vec3::from_slice(th),
        },
        |th| RigidBody {
            inertia: Vec3::from_slice(th),
        },
        &[1.0, 2.2, 2.9],
        &random_state(&body, 4),
    );
    check(
        "asymmetric top",
        |th| {
            let mut top = AsymmetricTop::default();
            top.body.inertia = Vec3::from_slice(th);
            top
        },
        |th| {
            let mut top = AsymmetricTop::default();
            top.body.inertia = Vec3::from_slice(th);
            top
        },
        &[1.3, 0.8, 2.1],
        &random_state(&body, 8),
    );
    let se3 = StateLayout::particles(&[Block::Se3], 1);
    check(
        "constant twist",
        |th| ConstantTwist {
            xi: Vec6::from_slice(th),
            ..Default::default()
        },
        |th| ConstantTwist {
            xi: Vec6::from_slice(th),
            ..Default::default()
        },
        &[0.3, -0.2, 0.9, 0.5, 0.1, -0.7],
        &random_state(&se3, 5),
    );
    check(
        "screw pair",
        |_| ScrewPair::default(),
        |_| ScrewPair::default(),
        &[],
        &random_state(&se3, 6),
    );
    let propelled = StateLayout::particles(&[Block::Se3, Block::Euclidean(3)], 1);
    check(
        "propelled top",
        |th| {
            let mut p = PropelledTop::default();
            p.top.body.inertia = Vec3::from_slice(th);
            p.speed = th[3];
            p
        },
        |th| {
            let mut p = PropelledTop::default();
            p.top.body.inertia = Vec3::from_slice(th);
            p.speed = th[3];
            p
        },
        &[1.0, 2.2, 2.9, 0.6],
        &random_state(&propelled, 7),
    );
}

/// The classic problems without closed forms, at parameters away from 1 (where a product
/// and a quotient by a parameter agree).
#[test]
fn classic_field_vjps() {
    let euclidean = |n| random_state(&StateLayout::euclidean(n), 9);
    check(
        "van der pol",
        |th| VanDerPol { mu: th[0] },
        |th| VanDerPol { mu: th[0] },
        &[1.7],
        &euclidean(2),
    );
    check(
        "kepler",
        |th| Kepler { mu: th[0] },
        |th| Kepler { mu: th[0] },
        &[0.8],
        &[0.9, -0.4, 0.3, 1.1],
    );
    check(
        "lorenz",
        |th| Lorenz {
            sigma: th[0],
            rho: th[1],
            beta: th[2],
        },
        |th| Lorenz {
            sigma: th[0],
            rho: th[1],
            beta: th[2],
        },
        &[9.0, 27.0, 2.5],
        &euclidean(3),
    );
    check(
        "euler rates",
        |th| EulerRates {
            inertia: [th[0], th[1], th[2]],
        },
        |th| EulerRates {
            inertia: [th[0], th[1], th[2]],
        },
        &[1.3, 0.8, 2.1],
        &euclidean(3),
    );
    check(
        "forced oscillator",
        |th| ForcedOscillator {
            a: th[0],
            w: th[1],
            c: th[2],
        },
        |th| ForcedOscillator {
            a: th[0],
            w: th[1],
            c: th[2],
        },
        &[0.6, 1.9, 0.3],
        &euclidean(2),
    );
}

/// Kepler's perihelion start and energy: every start of semi-major axis 1 has `E = −½`
/// (μ = 1), and a generic state has `|p|²/2 − μ/|q|`.
#[test]
fn kepler_start_and_energy_have_their_values() {
    let y: [f64; 4] = Kepler::initial_state(0.5);
    assert!(y.to_vec() == [0.5, 0.0, 0.0, 3.0_f64.sqrt()], "{y:?}");
    let unit = Kepler { mu: 1.0_f64 };
    for e in [0.0, 0.3, 0.6] {
        let energy = unit.energy(&Kepler::initial_state(e));
        assert!((energy + 0.5).abs() < 1e-15, "e = {e}: {energy}");
    }
    let energy = Kepler { mu: 0.8 }.energy(&[0.9, -0.4, 0.3, 1.1]);
    let want = 0.5 * (0.09 + 1.21) - 0.8 / 0.97_f64.sqrt();
    assert!((energy - want).abs() < 1e-15, "{energy} vs {want}");
}

#[test]
fn by_name_says_what_is_wrong() {
    let none = |_: &str| None;
    let short = |_: &str| Some(vec![1.0, 2.0]);
    let unknown = by_name("brusselator", &none).err().expect("unknown name");
    assert!(unknown == ProblemError::UnknownName, "{unknown:?}");
    assert!(
        unknown.to_string()
            == "unknown problem (expected van_der_pol, kepler, lorenz, rigid_body, \
                forced_oscillator)",
        "{unknown}"
    );
    let missing = by_name("van_der_pol", &none).err().expect("no μ");
    assert!(
        missing.to_string() == "parameter `mu` missing or of the wrong size",
        "{missing}"
    );
    let wrong = by_name("rigid_body", &short).err().expect("two moments");
    assert!(wrong == ProblemError::Parameter("inertia"), "{wrong:?}");
}

#[test]
fn euler_rates_energy_has_its_value() {
    let rates = EulerRates {
        inertia: [1.3_f64, 0.8, 2.1],
    };
    let energy = rates.energy(&[0.5, -1.5, 0.4]);
    let want = 0.5 * (1.3 * 0.25 + 0.8 * 2.25 + 2.1 * 0.16);
    assert!((energy - want).abs() < 1e-15, "{energy} vs {want}");
}

/// `(exact(t + ε) ⊖ exact(t − ε))/2ε` equals the field at `exact(t)` (tangent
/// coordinates: `Log(q₊ q₋*)` on SO(3) blocks, the world-frame rate; `Log(T₊ T₋⁻¹)` on
/// SE(3) blocks, the world-frame twist).
fn exact_solves_its_ode<P: ExactProblem<f64>>(p: &mut P) {
    let layout = p.layout();
    let (na, n) = (layout.ambient_len(), layout.tangent_len());
    let (mut yp, mut ym, mut y, mut f) =
        (vec![0.0; na], vec![0.0; na], vec![0.0; na], vec![0.0; n]);
    let mut y0 = vec![0.0; na];
    p.initial_state(&mut y0);
    p.exact(p.t0(), &mut y);
    assert!(
        p.error(&y0, &y) < 1e-15,
        "{}: exact(t0) = initial state",
        p.name()
    );
    let eps = 1e-5;
    for k in 1..=5 {
        let t = p.t0() + (p.t_end() - p.t0()) * f64::from(k) / 5.0;
        p.exact(t + eps, &mut yp);
        p.exact(t - eps, &mut ym);
        p.exact(t, &mut y);
        p.eval(t, &y, &mut f);
        let (pa, pt) = (layout.particle_ambient_len(), layout.particle_tangent_len());
        for q in 0..layout.count() {
            for sp in layout.spans() {
                let (o, ot) = (q * pa + sp.ambient, q * pt + sp.tangent);
                let d: Vec<f64> = match sp.block {
                    Block::Euclidean(m) => (0..m)
                        .map(|e| (yp[o + e] - ym[o + e]) / (2.0 * eps))
                        .collect(),
                    Block::So3 => {
                        let qd =
                            Quat::from_slice(&yp[o..]).mul_quat(Quat::from_slice(&ym[o..]).conj());
                        (log_quat(qd) * (0.5 / eps)).to_array().to_vec()
                    }
                    Block::Se3 => {
                        let d = Se3::from_slice(&yp[o..]) * Se3::from_slice(&ym[o..]).inverse();
                        (d.log() * (0.5 / eps)).to_array().to_vec()
                    }
                };
                for (e, v) in d.iter().enumerate() {
                    let want = f[ot + e];
                    assert!(
                        (v - want).abs() < 1e-8 * want.abs().max(1.0),
                        "{} at t={t}: {v} vs {want}",
                        p.name()
                    );
                }
            }
        }
    }
}

#[test]
fn closed_forms_solve_their_odes() {
    exact_solves_its_ode(&mut Logistic::default());
    exact_solves_its_ode(&mut CosGrowth::default());
    exact_solves_its_ode(&mut HarmonicOscillator::default());
    exact_solves_its_ode(&mut RotatingDecay::default());
    // The default starts on the first axis (x₂ = 0): one that starts off both axes.
    exact_solves_its_ode(&mut RotatingDecay {
        x0: [0.6, -1.3],
        ..Default::default()
    });
    exact_solves_its_ode(&mut ConstantRate::default());
    exact_solves_its_ode(&mut ProblemK);
    exact_solves_its_ode(&mut SymmetricTop::default());
    exact_solves_its_ode(&mut ConstantTwist::default());
    exact_solves_its_ode(&mut ScrewPair::default());
    exact_solves_its_ode(&mut PropelledTop::default());
    // The default tops have I₁ = I₂ = 1, where dividing by I₁ and multiplying by it agree.
    let mut flat = SymmetricTop::default();
    flat.body.inertia = Vec3::new(1.6, 1.6, 0.7);
    exact_solves_its_ode(&mut flat);
    exact_solves_its_ode(&mut PropelledTop {
        top: flat,
        ..Default::default()
    });
    // The default oscillator starts at rest (v₀ = 0): one that moves, and with ω ≠ 1.
    let mut moving = HarmonicOscillator {
        omega: 1.3,
        x0: -0.4,
        v0: 0.7,
        t_end: 3.0,
    };
    exact_solves_its_ode(&mut moving);
    // E = ½(v² + ω²x²), the same all along the exact solution.
    let e0 = 0.5 * (0.7 * 0.7 + (1.3 * 0.4_f64).powi(2));
    let mut y = [0.0; 2];
    for t in [0.0, 0.9, 2.5] {
        moving.exact(t, &mut y);
        let e = moving.energy(&y);
        assert!((e - e0).abs() < 1e-15, "energy {e} at t = {t}, {e0} at 0");
    }
    let top = AsymmetricTop::<f64>::default();
    let mut y = [0.0; 7];
    top.initial_state(&mut y);
    assert!(
        (top.body.energy(&y) - 0.5 * (1.0 + 2.0 * 0.01 + 3.0 * 0.25)).abs() < 1e-15,
        "energy"
    );
    // |Iω|² with Iω = (1, 0.2, 1.5).
    assert!(
        (top.body.momentum_squared(&y) - (1.0 + 0.04 + 2.25)).abs() < 1e-15,
        "|Iω|²"
    );
}

#[test]
fn parameter_accessors_read_and_write_the_parameters() {
    let a = vec![1.0, 2.0, 3.0, 4.0];
    let mut f = LinearField::new(2, a.clone());
    assert!(f.matrix() == a.as_slice());
    f.matrix_mut()[1] = -1.0;
    let mut dydt = [0.0; 2];
    f.eval(0.0, &[1.0, 1.0], &mut dydt);
    assert!(dydt.to_vec() == [0.0, 7.0], "{dydt:?}");

    let (n, h) = (3, 4);
    let mut rng = SplitMix64::new(5);
    let theta: Vec<f64> = (0..Mlp::<f64>::param_count(n, h))
        .map(|_| rng.uniform(-1.0, 1.0))
        .collect();
    let mut mlp = Mlp::new(n, h, theta.clone());
    assert!(mlp.params() == theta.as_slice());
    let (y, mut before, mut after) = ([0.3, -0.2, 0.5], [0.0; 3], [0.0; 3]);
    mlp.eval(0.4, &y, &mut before);
    // b3 is the last n parameters: the output's bias.
    let last = theta.len() - n;
    mlp.params_mut()[last] += 1.0;
    mlp.eval(0.4, &y, &mut after);
    assert!((after[0] - before[0] - 1.0).abs() < 1e-12 && after[1..] == before[1..]);
}
