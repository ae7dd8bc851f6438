//! Refining an orbit found by [`super::orbit::search`]: the body's own spin, and a last local
//! search over every parameter.
//!
//! A body on an orbit need not turn with it. In `toys` the torus circles the cube at 3π rad
//! per unit time about one axis while it tumbles at 4π about another, so a body turned rigidly
//! with its orbit (`spin = omega`) shows the wrong side of the ring within a few hundredths of
//! the range. The spin is three more numbers, searched like the orbit's velocity: a global
//! grid at the first horizon, then finer local grids at the later ones. Last, a compass search
//! (Kolda, Lewis and Torczon 2003) over the centre (3 numbers), the velocity (2) and the spin
//! (3), scored over every view of the last horizon, moves to the best of the 16 neighbours
//! while one improves and halves the steps when none does.

use super::orbit::{Group, Orbit, plane_basis};
use super::orbit_score::pick;
use super::spin::SearchContext;
use crate::model::Model;
use evogs_math::Vec3;
use evogs_ode::Stepper;

/// The spins `s0 + (a, b, c)·step`, `a, b, c ∈ −k..=k`, whose norm is at most `max`.
pub(super) fn spin_grid(s0: Vec3<f64>, step: f64, k: i64, max: f64) -> Vec<Vec3<f64>> {
    let mut out = Vec::new();
    for a in -k..=k {
        for b in -k..=k {
            for c in -k..=k {
                #[allow(clippy::cast_precision_loss, reason = "small integers")]
                let s = s0 + Vec3::new(a as f64, b as f64, c as f64) * step;
                if s.norm() <= max + 1e-9 {
                    out.push(s);
                }
            }
        }
    }
    out
}

/// The parameters [`neighbours`] moves: the centre's 3 coordinates, the velocity's 2 (in the
/// plane perpendicular to the radius) and the spin's 3.
const PARAMS: usize = 8;

/// Per-parameter steps from one step each for the centre, the velocity and the spin.
fn per_parameter([centre, velocity, spin]: [f64; 3]) -> [f64; PARAMS] {
    [centre, centre, centre, velocity, velocity, spin, spin, spin]
}

/// The neighbours of `o` for the body centred at `c0`, each with the parameter it moves:
/// parameter `j` moved by `+steps[j]`, then (after all of those) by `−steps[j]`, for every
/// `j` whose step is not zero. The parameters are the centre along each axis (the centroid's
/// velocity kept), the velocity along the two directions perpendicular to `c0 − centre`,
/// and the spin along each axis.
pub(super) fn neighbours(o: &Orbit, c0: Vec3<f64>, steps: [f64; PARAMS]) -> Vec<(usize, Orbit)> {
    let v = o.velocity_at(c0);
    let axes = [
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
    ];
    let (e1, e2) = plane_basis(c0 - o.centre);
    let moved = |j: usize, d: f64| match j {
        0..=2 => Orbit::through(c0, o.centre + axes[j] * d, v).with_spin(o.spin),
        3 | 4 => Orbit::through(c0, o.centre, v + [e1, e2][j - 3] * d).with_spin(o.spin),
        _ => o.with_spin(o.spin + axes[j - 5] * d),
    };
    [1.0, -1.0]
        .into_iter()
        .flat_map(|sign| (0..PARAMS).map(move |j| (j, sign * steps[j])))
        .filter(|&(_, d)| d != 0.0)
        .map(|(j, d)| (j, moved(j, d)))
        .collect()
}

/// The compass search from `start` over `rounds` rounds, with the initial `steps` of the
/// centre, the velocity and the spin, scored over the views up to `horizon` (fraction of
/// `range`, start and length). Each round moves to the best of the [`neighbours`] (16 when
/// no step is zero) if it beats the current orbit and doubles that parameter's step (so a
/// long way is covered in few rounds), or else halves every step. Returns the orbit and its
/// gain (mean loss per view below the model's own motion).
#[allow(clippy::too_many_arguments, reason = "the search's whole state")]
pub(super) fn polish(
    model: &mut Model<f32>,
    ctx: &SearchContext<'_>,
    group: &Group,
    start: Orbit,
    (steps, rounds): ([f64; 3], usize),
    range_horizon: ((f64, f64), f64),
    stepper: &mut Option<Stepper<f32>>,
    log: &mut dyn FnMut(&str),
) -> (Orbit, f64) {
    let mut steps = per_parameter(steps);
    let mut best = start;
    let mut gain = f64::NEG_INFINITY;
    for round in 0..rounds {
        let moves = neighbours(&best, group.centroid, steps);
        let mut cands = vec![best];
        cands.extend(moves.iter().map(|&(_, o)| o));
        let p = pick(model, ctx, group, &cands, range_horizon, stepper);
        gain = p.gain;
        let moved = p.index != 0;
        if moved {
            best = p.orbit;
            steps[moves[p.index - 1].0] *= 2.0;
        } else {
            steps = steps.map(|s| s * 0.5);
        }
        log(&format!(
            "orbit search: polish round {round} ({} views): {}, centre {:.3?}, |Ω| {:.3}, spin {:.2?}, {:+.2e} per view",
            p.views,
            if moved { "moved" } else { "steps halved" },
            best.centre.to_array(),
            best.omega.norm(),
            best.spin.to_array(),
            -gain
        ));
    }
    (best, gain)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::test_support::{
        orbit_search_logged, orbit_test_cfg, static_model, test_context, tumbling_rod,
    };
    use crate::train::step::render_options;
    use evogs_math::Par;

    #[test]
    fn the_search_finds_a_tumbling_body_s_own_spin() {
        // A rod circling the large group while it tumbles.
        let (splats, views, groups, truth) = tumbling_rod();
        let cfg = orbit_test_cfg();
        let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
        let mut model = static_model(&splats);
        let mut ctx = test_context(&views, &splats, opts);
        let mut lines = Vec::new();
        let mut run = |cfg: &crate::motion::OrbitSearchConfig| {
            orbit_search_logged(&mut model, &mut ctx, &groups, cfg, &mut lines)
        };
        let found = run(&cfg);
        let locked = run(&crate::motion::OrbitSearchConfig {
            max_spin: 0.0,
            ..cfg.clone()
        });
        assert_eq!((found.len(), locked.len()), (1, 1), "{lines:#?}");
        let f = &found[0].orbit;
        // The last spin step is 0.25, the last velocity step 0.125 (0.2 rad per unit time).
        assert!((f.spin - truth.spin).norm() < 0.3, "{f:?}");
        assert!((f.omega - truth.omega).norm() < 0.3, "{f:?}");
        assert!((f.centre - truth.centre).norm() < 0.03, "{f:?}");
        // Turning with the orbit, the body fits the views worse.
        assert!(found[0].gain > locked[0].gain + 1e-4, "{lines:#?}");
    }

    #[test]
    fn the_spin_grid_is_the_lattice_within_the_ball() {
        let g = spin_grid(Vec3::zero(), 1.0, 2, 2.0);
        // The lattice points of norm at most 2: 1 + 6 + 12 + 8 + 6.
        assert_eq!(g.len(), 33);
        assert!(g.iter().all(|s| s.norm() <= 2.0 + 1e-12));
        let local = spin_grid(Vec3::new(5.0, 0.0, 0.0), 0.5, 1, f64::INFINITY);
        assert_eq!(local.len(), 27);
    }

    #[test]
    fn neighbours_keep_the_velocity_or_the_centre_and_move_one_thing() {
        let c0 = Vec3::new(0.6, 0.1, -0.2);
        let o = Orbit::through(c0, Vec3::new(0.1, 0.0, 0.3), Vec3::new(0.3, 2.0, -1.0))
            .with_spin(Vec3::new(1.0, -2.0, 0.5));
        let n = neighbours(&o, c0, per_parameter([0.01, 0.1, 0.5]));
        assert_eq!(n.len(), 16);
        let v = o.velocity_at(c0);
        for (k, &(j, ref m)) in n.iter().enumerate() {
            assert_eq!(j, k % PARAMS);
            let (dc, dv, ds) = (
                (m.centre - o.centre).norm(),
                (m.velocity_at(c0) - v).norm(),
                (m.spin - o.spin).norm(),
            );
            match j {
                0..=2 => {
                    // The centre moved; the velocity is kept up to its part along the new
                    // radius, which an orbit cannot have.
                    assert!((dc - 0.01).abs() < 1e-12 && ds == 0.0);
                    let r = c0 - m.centre;
                    let v_perp = v - r * (v.dot(r) / r.norm_squared());
                    assert!((m.velocity_at(c0) - v_perp).norm() < 1e-12, "{k}");
                }
                3 | 4 => {
                    assert!(dc == 0.0 && (dv - 0.1).abs() < 1e-12 && ds == 0.0, "{k}");
                }
                _ => assert!(dc == 0.0 && dv < 1e-12 && (ds - 0.5).abs() < 1e-12, "{k}"),
            }
        }
        // A parameter whose step is zero is not moved (no copies of `o` to score).
        assert_eq!(
            neighbours(&o, c0, per_parameter([0.01, 0.1, 0.0])).len(),
            10
        );
    }
}
