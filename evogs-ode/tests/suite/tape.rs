//! The recorded integration and its adjoint ([`integrate_recorded`],
//! [`discrete_adjoint_recorded`]): bitwise the trajectory and gradient of
//! [`integrate_trajectory`] and [`discrete_adjoint`] for every tape capacity, each stage's VJP
//! reading the record its own evaluation wrote, and the steps that were not kept evaluated
//! exactly once more.

use crate::common;

use common::{CoupledField, random_state};
use evogs_math::rng::SplitMix64;
use evogs_ode::{
    Checkpointing, Method, StageTape, StateLayout, Stepper, TimeGrid, Trajectory, VectorField,
    discrete_adjoint, discrete_adjoint_recorded, integrate_recorded, integrate_trajectory,
};

/// A field whose record is the point it was evaluated at: its VJP checks that it is handed
/// the record of its own evaluation. Counts evaluations.
struct Recording {
    inner: CoupledField<f64>,
    evals: usize,
    recorded_vjps: usize,
}

impl VectorField<f64> for Recording {
    type Record = Option<(f64, Vec<f64>)>;
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn layout(&self) -> StateLayout {
        self.inner.layout()
    }
    fn n_params(&self) -> usize {
        self.inner.n_params()
    }
    fn eval(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        self.evals += 1;
        self.inner.eval(t, y, dydt);
    }
    fn vjp(&mut self, t: f64, y: &[f64], w: &[f64], d_y: &mut [f64], d_params: &mut [f64]) {
        self.inner.vjp(t, y, w, d_y, d_params);
    }
    fn eval_recorded(&mut self, t: f64, y: &[f64], dydt: &mut [f64], record: &mut Self::Record) {
        self.eval(t, y, dydt);
        *record = Some((t, y.to_vec()));
    }
    fn vjp_recorded(
        &mut self,
        t: f64,
        y: &[f64],
        record: &Self::Record,
        w: &[f64],
        d_y: &mut [f64],
        d_params: &mut [f64],
    ) {
        let (rt, ry) = record.as_ref().expect("a written record");
        assert!(
            rt.to_bits() == t.to_bits() && ry == y,
            "the VJP got the record of another stage"
        );
        self.recorded_vjps += 1;
        self.vjp(t, y, w, d_y, d_params);
    }
}

/// [`discrete_adjoint_recorded`] of the cotangent of ones (the gradients are dropped).
fn recorded_adjoint_of_ones<F: VectorField<f64>>(
    f: &mut F,
    st: &mut Stepper<f64>,
    traj: &Trajectory<f64>,
    tape: &mut StageTape<f64, F::Record>,
) {
    let n = f.dim();
    let (mut d_y0, mut d_p) = (vec![0.0; n], vec![0.0; f.n_params()]);
    discrete_adjoint_recorded(f, st, traj, tape, &vec![1.0; n], &mut d_y0, &mut d_p);
}

#[test]
fn the_recorded_adjoint_is_bitwise_the_plain_one_for_every_capacity() {
    let count = 3;
    let y0 = random_state(&CoupledField::<f64>::layout_for(count), 5);
    let grid = TimeGrid::uniform(0.0, 0.9, 5);
    let mut rng = SplitMix64::new(9);
    let n = CoupledField::<f64>::layout_for(count).tangent_len();
    let d_final: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
    for method in [Method::Euler, Method::Midpoint, Method::Rk4] {
        let stages = method.stages();
        let mut f = Recording {
            inner: CoupledField::random(count, 7),
            evals: 0,
            recorded_vjps: 0,
        };
        let mut st = Stepper::new(method, f.layout());
        let plain = integrate_trajectory(&mut f, &mut st, &grid, &y0, Checkpointing::StoreAll);
        let (mut d_y0, mut d_p) = (vec![0.0; n], vec![0.0; f.n_params()]);
        discrete_adjoint(&mut f, &mut st, &plain, &d_final, &mut d_y0, &mut d_p);
        // One tape for every capacity: its buffers are reused from run to run.
        let mut tape = StageTape::new(0);
        for capacity in 0..=5 * stages + 1 {
            tape.set_capacity(capacity);
            f.evals = 0;
            f.recorded_vjps = 0;
            let traj = integrate_recorded(&mut f, &mut st, &grid, &y0, &mut tape);
            let kept = tape.kept_stages();
            assert_eq!(
                kept,
                (capacity / stages).min(5) * stages,
                "{method}: whole steps"
            );
            assert!(
                traj.final_state() == plain.final_state(),
                "{method} {capacity}: trajectory"
            );
            assert_eq!(
                traj.stored_states(),
                plain.stored_states(),
                "{method} {capacity}: every state once, no more"
            );
            let (mut e_y0, mut e_p) = (vec![0.0; n], vec![0.0; f.n_params()]);
            discrete_adjoint_recorded(
                &mut f, &mut st, &traj, &mut tape, &d_final, &mut e_y0, &mut e_p,
            );
            assert!(e_y0 == d_y0 && e_p == d_p, "{method} {capacity}: gradient");
            assert_eq!(
                f.recorded_vjps,
                5 * stages,
                "{method}: every VJP from a record"
            );
            assert_eq!(
                f.evals,
                5 * stages + (5 * stages - kept),
                "{method} {capacity}: the steps not kept are evaluated once more"
            );
            // The kept steps' stages go back to the tape after their reverse pass.
            let (mut g_y0, mut g_p) = (vec![0.0; n], vec![0.0; f.n_params()]);
            discrete_adjoint_recorded(
                &mut f, &mut st, &traj, &mut tape, &d_final, &mut g_y0, &mut g_p,
            );
            assert!(
                g_y0 == d_y0 && g_p == d_p,
                "{method} {capacity}: a second reverse pass of the same tape"
            );
        }
    }
}

#[test]
#[should_panic(expected = "not recorded with this trajectory")]
fn a_tape_of_another_run_is_refused() {
    let count = 2;
    let y0 = random_state(&CoupledField::<f64>::layout_for(count), 5);
    let mut f = Recording {
        inner: CoupledField::random(count, 7),
        evals: 0,
        recorded_vjps: 0,
    };
    let mut st = Stepper::new(Method::Rk4, f.layout());
    let mut tape = StageTape::new(8);
    let traj = integrate_recorded(
        &mut f,
        &mut st,
        &TimeGrid::uniform(0.0, 1.0, 4),
        &y0,
        &mut tape,
    );
    let _ = integrate_recorded(
        &mut f,
        &mut st,
        &TimeGrid::uniform(0.0, 1.0, 3),
        &y0,
        &mut tape,
    );
    recorded_adjoint_of_ones(&mut f, &mut st, &traj, &mut tape);
}

thread_local! {
    /// Records made by [`Counted::default`] on this thread.
    static RECORDS_MADE: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// A record that counts how many the tape makes: the tape's memory budget is in records.
struct Counted;

impl Default for Counted {
    fn default() -> Self {
        RECORDS_MADE.with(|n| n.set(n.get() + 1));
        Self
    }
}

/// [`Recording`]'s field with a counted record.
struct CountedField(CoupledField<f64>);

impl VectorField<f64> for CountedField {
    type Record = Counted;
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn layout(&self) -> StateLayout {
        self.0.layout()
    }
    fn n_params(&self) -> usize {
        self.0.n_params()
    }
    fn eval(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        self.0.eval(t, y, dydt);
    }
    fn vjp(&mut self, t: f64, y: &[f64], w: &[f64], d_y: &mut [f64], d_params: &mut [f64]) {
        self.0.vjp(t, y, w, d_y, d_params);
    }
}

#[test]
fn the_tape_makes_no_more_records_than_its_capacity_and_the_steps_it_drops() {
    let count = 2;
    let layout = CoupledField::<f64>::layout_for(count);
    let y0 = random_state(&layout, 3);
    let grid = TimeGrid::uniform(0.0, 1.0, 10);
    let mut f = CountedField(CoupledField::random(count, 4));
    let mut st = Stepper::new(Method::Rk4, f.layout());
    let made = || RECORDS_MADE.with(core::cell::Cell::get);
    // (capacity, records the forward makes, scratch records the reverse makes)
    for (capacity, forward, scratch) in [(8, 8, 4), (40, 40, 0), (41, 40, 0), (3, 0, 4)] {
        let mut tape = StageTape::new(capacity);
        assert_eq!(tape.capacity(), capacity);
        let before = made();
        let traj = integrate_recorded(&mut f, &mut st, &grid, &y0, &mut tape);
        assert_eq!(made() - before, forward, "capacity {capacity}: forward");
        let before = made();
        recorded_adjoint_of_ones(&mut f, &mut st, &traj, &mut tape);
        assert_eq!(made() - before, scratch, "capacity {capacity}: reverse");
        tape.set_capacity(capacity / 2);
        assert_eq!(tape.capacity(), capacity / 2);
    }
}
