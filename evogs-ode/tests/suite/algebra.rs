//! Vector-field algebra: every composite's VJP against central differences (state
//! perturbed in tangent coordinates, SO(3) blocks by Exp(δ)·R) and against dual numbers;
//! masks; and the exactness of an injected rigid rotation.

use crate::common;

use common::{CoupledField, random_state, retract};
use evogs_math::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_quat;
use evogs_math::{Dual, Quat, Real, Vec3};
use evogs_ode::algebra::{
    Edge, FrameError, Mask, Mix, ParticleFrame, RigidRotation, Scaled, Sum, Translation,
};
use evogs_ode::{Block, Method, StateLayout, Stepper, TimeGrid, VectorField, integrate};

const COUNT: usize = 4;

fn frame() -> ParticleFrame {
    ParticleFrame::new(CoupledField::<f64>::layout_for(COUNT), 0, Some(1)).expect("frame")
}

fn v3<T: Real>(x: f64, y: f64, z: f64) -> Vec3<T> {
    Vec3::new(T::from_f64(x), T::from_f64(y), T::from_f64(z))
}

/// Checks `vjp` of the field built from θ against central differences of `w·f(y ⊕ δ; θ)`
/// in `[δ, θ]`, and that it accumulates.
fn check_vjp<F: VectorField<f64>>(
    what: &str,
    make: impl Fn(&[f64]) -> F,
    theta: &[f64],
    y: &[f64],
) {
    let mut f = make(theta);
    let layout = f.layout();
    let n = layout.tangent_len();
    assert_eq!(f.dim(), n, "{what}: dim is the layout's tangent length");
    assert_eq!(f.n_params(), theta.len(), "{what}: n_params");
    let mut rng = SplitMix64::new(99);
    let w: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let t = 0.37;
    // Accumulation: start from ones and subtract them afterwards.
    let mut d_y = vec![1.0; n];
    let mut d_th = vec![1.0; theta.len()];
    f.vjp(t, y, &w, &mut d_y, &mut d_th);
    let mut analytic: Vec<f64> = d_y.iter().chain(&d_th).map(|v| v - 1.0).collect();
    let mut x = vec![0.0; n];
    x.extend_from_slice(theta);
    let mut numeric = vec![0.0; x.len()];
    let mut out = vec![0.0; n];
    central_gradient(
        |v: &[f64]| {
            let mut g = make(&v[n..]);
            g.eval(t, &retract(&layout, y, &v[..n]), &mut out);
            out.iter().zip(&w).map(|(a, b)| a * b).sum()
        },
        &mut x,
        &mut numeric,
    );
    let rep = GradCheck::new(1e-9, 1e-7).check(&analytic, &numeric);
    rep.assert_passed(what);
    println!("{what:>28}: {rep}");
    analytic.clear();
}

/// A state whose particles sit at chosen positions (others random).
fn state_with_positions(positions: &[[f64; 3]]) -> Vec<f64> {
    let layout = CoupledField::<f64>::layout_for(COUNT);
    let mut y = random_state(&layout, 4);
    for (p, pos) in positions.iter().enumerate() {
        y[9 * p..9 * p + 3].copy_from_slice(pos);
    }
    y
}

const POS: [[f64; 3]; COUNT] = [
    [0.1, 0.2, -0.05],  // inside the sphere and the box (off the box SDF's medial axis)
    [0.9, -0.4, 0.3],   // near the sphere's surface, outside the box
    [1.8, 1.1, -0.9],   // outside both
    [-0.35, 0.1, 0.55], // near the box's top face
];

fn rigid<T: Real>(th: &[T]) -> RigidRotation<T> {
    RigidRotation::new(frame(), Vec3::from_slice(th), Vec3::from_slice(&th[3..]))
}

fn coupled<T: Real>(th: &[T]) -> CoupledField<T> {
    CoupledField {
        theta: th.to_vec(),
        count: COUNT,
    }
}

fn rigid_theta() -> Vec<f64> {
    vec![0.3, -0.8, 1.1, 0.2, -0.1, 0.4]
}

fn mix_theta() -> Vec<f64> {
    let mut th = rigid_theta();
    th.extend(CoupledField::<f64>::random(COUNT, 5).theta);
    th
}

fn soft_sphere<T: Real>() -> Mask<T> {
    Mask::Sphere {
        center: v3(0.0, 0.0, 0.1),
        radius: T::from_f64(1.0),
        edge: Edge::Soft {
            width: T::from_f64(0.3),
        },
    }
}

fn soft_box<T: Real>() -> Mask<T> {
    Mask::Box {
        min: v3(-0.5, -0.6, -0.4),
        max: v3(0.6, 0.5, 0.5),
        edge: Edge::Soft {
            width: T::from_f64(0.2),
        },
    }
}

fn mixed<T: Real>(mask: Mask<T>, th: &[T]) -> Mix<T, RigidRotation<T>, CoupledField<T>> {
    Mix::new(mask, rigid(&th[..6]), coupled(&th[6..]), frame())
}

#[test]
fn leaf_field_vjps_match_central_differences() {
    let y = state_with_positions(&POS);
    check_vjp("rigid rotation", rigid, &rigid_theta(), &y);
    check_vjp(
        "translation",
        |th| Translation::new(frame(), Vec3::from_slice(th)),
        &[0.4, -1.0, 0.2],
        &y,
    );
    let points = ParticleFrame::points(3);
    let yp = random_state(&points.layout(), 7);
    check_vjp(
        "rigid rotation (points)",
        |th| RigidRotation::new(points, Vec3::from_slice(th), Vec3::from_slice(&th[3..])),
        &rigid_theta(),
        &yp,
    );
    check_vjp(
        "coupled test field",
        coupled,
        &CoupledField::<f64>::random(COUNT, 5).theta,
        &y,
    );
}

#[test]
fn composite_vjps_match_central_differences() {
    let y = state_with_positions(&POS);
    let th = mix_theta();
    check_vjp(
        "sum",
        |th| Sum::new(rigid(&th[..6]), coupled(&th[6..])),
        &th,
        &y,
    );
    check_vjp("scaled", |th| Scaled::new(-1.7, coupled(th)), &th[6..], &y);
    check_vjp("mix, soft sphere", |th| mixed(soft_sphere(), th), &th, &y);
    check_vjp("mix, soft box", |th| mixed(soft_box(), th), &th, &y);
    let hard_sphere = Mask::Sphere {
        center: v3(0.0, 0.0, 0.1),
        radius: 1.0,
        edge: Edge::Hard,
    };
    check_vjp(
        "mix, hard sphere",
        |th| mixed(hard_sphere.clone(), th),
        &th,
        &y,
    );
    let hard_box = Mask::Box {
        min: v3(-0.5, -0.6, -0.4),
        max: v3(0.6, 0.5, 0.5),
        edge: Edge::Hard,
    };
    check_vjp("mix, hard box", |th| mixed(hard_box.clone(), th), &th, &y);
    let weights = Mask::Weights(vec![1.0, 0.25, 0.0, 0.6]);
    check_vjp(
        "mix, explicit weights",
        |th| mixed(weights.clone(), th),
        &th,
        &y,
    );
    check_vjp(
        "nested: mix of sums",
        |th| {
            Mix::new(
                soft_sphere(),
                Sum::new(
                    rigid(&th[..6]),
                    Translation::new(frame(), Vec3::from_slice(&th[6..])),
                ),
                Scaled::new(0.5, coupled(&th[9..])),
                frame(),
            )
        },
        &[
            rigid_theta(),
            vec![0.1, 0.2, -0.3],
            CoupledField::<f64>::random(COUNT, 6).theta,
        ]
        .concat(),
        &y,
    );
}

#[test]
fn a_scaled_field_follows_its_factor() {
    let y = state_with_positions(&POS);
    let mut f = Scaled::new(-1.7, coupled(&CoupledField::<f64>::random(COUNT, 5).theta));
    let n = f.dim();
    let (mut before, mut after) = (vec![0.0; n], vec![0.0; n]);
    f.eval(0.3, &y, &mut before);
    f.set_factor(3.4);
    assert!(f.factor().to_bits() == 3.4_f64.to_bits());
    f.eval(0.3, &y, &mut after);
    for (a, b) in after.iter().zip(&before) {
        assert!((a + 2.0 * b).abs() <= 1e-15 * a.abs(), "{a} against −2·{b}");
    }
}

/// The same generic field run on dual numbers gives the exact JVP: the dot-product test
/// then checks the VJP to rounding.
#[test]
fn mix_vjp_passes_the_dual_dot_product_test() {
    let y = state_with_positions(&POS);
    let th = mix_theta();
    let layout = frame().layout();
    let n = layout.tangent_len();
    for (name, mask_f, mask_d) in [
        (
            "soft sphere",
            soft_sphere::<f64>(),
            soft_sphere::<Dual<f64>>(),
        ),
        ("soft box", soft_box::<f64>(), soft_box::<Dual<f64>>()),
    ] {
        let x0: Vec<f64> = vec![0.0; n].into_iter().chain(th.iter().copied()).collect();
        let r = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                dual_jvp(
                    |x: &[Dual<f64>], o: &mut [Dual<f64>]| {
                        let yd: Vec<Dual<f64>> = y.iter().map(|&a| Dual::constant(a)).collect();
                        let mut f = mixed(mask_d.clone(), &x[n..]);
                        f.eval(Dual::constant(0.37), &retract(&layout, &yd, &x[..n]), o);
                    },
                    &x0,
                    v,
                    out,
                );
            },
            |w: &[f64], out: &mut [f64]| {
                out.fill(0.0);
                let (dy, dth) = out.split_at_mut(n);
                mixed(mask_f.clone(), &th).vjp(0.37, &y, w, dy, dth);
            },
            n + th.len(),
            n,
            3,
        );
        assert!(r < 1e-13, "{name}: dot-product residual {r:e}");
    }
}

#[test]
fn masks_have_the_documented_values() {
    let s = soft_sphere::<f64>();
    let on_surface = Vec3::new(1.0, 0.0, 0.1);
    assert!(
        (s.weight(0, on_surface) - 0.5).abs() < 1e-15,
        "½ on the surface"
    );
    let one_width_inside = Vec3::new(0.7, 0.0, 0.1);
    assert!(
        (s.weight(0, one_width_inside) - 1.0 / (1.0 + (-1.0_f64).exp())).abs() < 1e-15,
        "σ(1)"
    );
    let b = Mask::Box {
        min: v3(0.0, 0.0, 0.0),
        max: v3(2.0, 2.0, 2.0),
        edge: Edge::Hard,
    };
    let (d, g) = b.signed_distance(Vec3::new(1.0, 1.5, 1.0)).expect("shape");
    assert!(
        (d + 0.5).abs() < 1e-15 && (g.y - 1.0).abs() < 1e-15,
        "inside: nearest face"
    );
    let (d, _) = b.signed_distance(Vec3::new(3.0, 3.0, 1.0)).expect("shape");
    assert!((d - 2.0_f64.sqrt()).abs() < 1e-15, "outside a corner edge");
    // Exactly on a face the distance is 0 and the gradient that face's normal; at a
    // sphere's centre the gradient is zero: never NaN.
    let (d, g) = b.signed_distance(Vec3::new(1.0, 2.0, 1.5)).expect("shape");
    assert!(
        [d, g.x, g.y, g.z].to_vec() == [0.0, 0.0, 1.0, 0.0],
        "on a face: {d} {g:?}"
    );
    let (d, g) = s.signed_distance(Vec3::new(0.0, 0.0, 0.1)).expect("shape");
    assert!(
        [d, g.x, g.y, g.z].to_vec() == [-1.0, 0.0, 0.0, 0.0],
        "at the centre: {d} {g:?}"
    );
    assert!(
        b.weight(0, Vec3::new(2.0, 1.0, 1.0)) > 0.5,
        "hard edge includes the surface"
    );
    assert!(
        b.weight(0, Vec3::new(2.0 + 1e-12, 1.0, 1.0)) < 0.5,
        "and nothing beyond"
    );
    let m = Mask::<f64>::from_indices(4, &[1, 3]);
    assert_eq!(
        m,
        Mask::Weights(vec![0.0, 1.0, 0.0, 1.0]),
        "per-particle list"
    );
    assert_eq!(
        ParticleFrame::new(frame().layout(), 1, None),
        Err(FrameError::NotAPosition(1)),
        "a rotation block is not a position"
    );
    assert_eq!(
        ParticleFrame::new(frame().layout(), 0, Some(2)),
        Err(FrameError::NotARotation(2)),
        "E(2)"
    );
    assert_eq!(
        ParticleFrame::new(frame().layout(), 0, Some(9)),
        Err(FrameError::NoSuchBlock(9)),
        "range"
    );
}

/// A frame finds its blocks wherever they sit in the particle, and its errors name the block.
#[test]
fn a_frame_finds_its_blocks_wherever_they_sit() {
    // [So3, Euclidean(2), Euclidean(3)]: the position starts at ambient entry 4 + 2 and
    // tangent entry 3 + 2 of a particle of 9 ambient, 8 tangent entries.
    let layout = StateLayout::particles(&[Block::So3, Block::Euclidean(2), Block::Euclidean(3)], 3);
    let frame = ParticleFrame::new(layout, 2, Some(0)).expect("frame");
    for p in 0..3 {
        assert_eq!(frame.position_ambient(p), 9 * p + 6);
        assert_eq!(frame.position_tangent(p), 8 * p + 5);
        assert_eq!(frame.rotation_tangent(p), Some(8 * p));
    }
    let rotation = frame.rotation_span().expect("a rotation");
    assert_eq!(
        (rotation.block, rotation.ambient, rotation.tangent),
        (Block::So3, 0, 0)
    );
    assert_eq!(
        ParticleFrame::new(layout, 2, None)
            .expect("frame")
            .rotation_span(),
        None
    );
    for (error, message) in [
        (
            FrameError::NoSuchBlock(7),
            "block 7 is not in the particle pattern",
        ),
        (
            FrameError::NotAPosition(1),
            "block 1 is not a 3D position (Euclidean(3))",
        ),
        (
            FrameError::NotARotation(2),
            "block 2 is not a rotation (So3)",
        ),
    ] {
        assert_eq!(error.to_string(), message);
    }
}

/// An injected rotation turns orientations exactly (RKMK integrates a constant world rate
/// exactly) and positions to the stepper's accuracy.
#[test]
fn injected_rigid_rotation_turns_orientations_exactly() {
    let frame = ParticleFrame::oriented_points(50);
    let layout = frame.layout();
    let y0 = random_state(&layout, 12);
    let (omega, center) = (Vec3::new(0.4, -1.1, 0.7), Vec3::new(0.2, 0.1, -0.3));
    let t_end = 2.5;
    let mut field = RigidRotation::new(frame, omega, center);
    let mut exact = y0.clone();
    for p in 0..50 {
        let x = Vec3::from_slice(&y0[7 * p..]);
        (center + exp_quat(omega * t_end).rotate(x - center)).write_to(&mut exact[7 * p..]);
        exp_quat(omega * t_end)
            .mul_quat(Quat::from_slice(&y0[7 * p + 3..]))
            .write_to(&mut exact[7 * p + 3..]);
    }
    for m in Method::ALL {
        let mut pos_err = Vec::new();
        for n in [16, 32] {
            let mut st = Stepper::new(m, layout);
            let mut y = y0.clone();
            integrate(
                &mut field,
                &mut st,
                &TimeGrid::uniform(0.0, t_end, n),
                &mut y,
            );
            let mut worst_angle: f64 = 0.0;
            let mut worst_pos: f64 = 0.0;
            for p in 0..50 {
                let q = Quat::from_slice(&y[7 * p + 3..]);
                let qe = Quat::from_slice(&exact[7 * p + 3..]);
                worst_angle =
                    worst_angle.max(evogs_math::so3::log_quat(qe.conj().mul_quat(q)).norm());
                worst_pos = worst_pos.max(
                    (Vec3::from_slice(&y[7 * p..]) - Vec3::from_slice(&exact[7 * p..])).norm(),
                );
            }
            assert!(
                worst_angle < 1e-14,
                "{m} N={n}: orientation error {worst_angle:e}"
            );
            pos_err.push(worst_pos);
        }
        let observed = (pos_err[0] / pos_err[1]).log2();
        println!(
            "{m}: orientation exact, position error {:.1e} → {:.1e} (order {observed:.2})",
            pos_err[0], pos_err[1]
        );
        assert!(
            (observed - m.order() as f64).abs() < 0.3,
            "{m}: position order {observed:.2}"
        );
    }
}

/// Particles are independent under a rigid rotation: each of 1500 points (three chunks of
/// the steppers' per-particle loops) ends bitwise where it ends when integrated alone.
#[test]
fn points_in_every_chunk_move_as_if_alone() {
    let (omega, center) = (Vec3::new(0.3, -0.2, 0.5), Vec3::new(0.1, 0.0, -0.1));
    let count = 1500;
    let mut all = RigidRotation::new(ParticleFrame::points(count), omega, center);
    let mut one = RigidRotation::new(ParticleFrame::points(1), omega, center);
    let y0 = random_state(&all.layout(), 3);
    let grid = TimeGrid::uniform(0.0, 0.7, 5);
    for m in [Method::Euler, Method::Rk4, Method::Rk38] {
        let mut y = y0.clone();
        let mut stepper = Stepper::new(m, all.layout());
        integrate(&mut all, &mut stepper, &grid, &mut y);
        let mut st = Stepper::new(m, one.layout());
        for p in [0, 511, 512, 1100, count - 1] {
            let mut alone = y0[3 * p..3 * p + 3].to_vec();
            integrate(&mut one, &mut st, &grid, &mut alone);
            assert!(alone == y[3 * p..3 * p + 3], "{m}: point {p}");
        }
    }
}
