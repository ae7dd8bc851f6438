//! [`StageTape`]: the stages a recorded integration keeps for its discrete adjoint.
//!
//! The discrete adjoint takes, step by step in reverse, the VJP of every stage the forward
//! pass evaluated, at the same points. A field whose VJP needs its forward pass (the neural
//! field's activations) would otherwise run it again, and the stepper would form each
//! stage's state again (exponentials and `dexp⁻¹` on the Lie-group blocks).
//! [`integrate_recorded`] writes each stage's field value and the field's
//! [`Record`](crate::VectorField::Record) into a tape that the caller owns, with the step's
//! stage slopes, states and increments (the stepper's own buffers, exchanged with the
//! tape's, not copied), and [`discrete_adjoint_recorded`] hands them back to the stepper in
//! reverse order, step by step, by their position in the grid: nothing is looked up by
//! value, and no stage of a kept step is formed again. The tape keeps the records of the
//! **last** whole steps that fit its capacity (the caller's memory budget, in stage
//! records): the reverse pass meets those first, and evaluates the earlier steps' stages
//! again (into scratch records reused from step to step).
//! Either way the gradient is bitwise the same as [`discrete_adjoint`](crate::discrete_adjoint)'s.

use crate::stepper::{KeptStep, StageBuffers};
use crate::{StateLayout, Stepper, TimeGrid, Trajectory, VectorField};
use alloc::vec::Vec;
use evogs_math::Real;

/// The stage values and field records of a [`integrate_recorded`] run, for
/// [`discrete_adjoint_recorded`] (see the module docs). Buffers are kept between runs and
/// only grow (up to the capacity).
#[derive(Clone, Debug)]
pub struct StageTape<T, R> {
    /// Stage records the tape may hold.
    capacity: usize,
    /// Steps and stages per step of the recorded run, and the tangent dimension.
    steps: usize,
    stages: usize,
    dim: usize,
    /// The first step whose stages are kept (the later ones all are).
    first_kept: usize,
    /// The kept steps' stage values, `dim` each, step-major.
    outputs: Vec<T>,
    /// The kept steps' field records, step-major (possibly more, unused, from an earlier
    /// run).
    records: Vec<R>,
    /// The kept steps' stage slopes, states and increments, one set per step (exchanged
    /// with the stepper's buffers, never copied).
    stages_kept: Vec<StageBuffers<T>>,
    /// Records for the stages the reverse pass evaluates again.
    scratch: Vec<R>,
}

impl<T: Real, R: Default> StageTape<T, R> {
    /// An empty tape that keeps at most `capacity` stage records.
    #[must_use]
    pub const fn new(capacity: usize) -> Self {
        Self {
            capacity,
            steps: 0,
            stages: 0,
            dim: 0,
            first_kept: 0,
            outputs: Vec::new(),
            records: Vec::new(),
            stages_kept: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// The scalars the tape keeps per kept stage of a state with this layout, beside the
    /// field's record: the stage's field value, slope and increment (tangent length each)
    /// and its state (ambient length).
    #[must_use]
    pub fn scalars_per_stage(layout: &StateLayout) -> usize {
        3 * layout.tangent_len() + layout.ambient_len()
    }

    /// The most stage records the tape keeps.
    #[must_use]
    pub const fn capacity(&self) -> usize {
        self.capacity
    }

    /// Sets the most stage records the next recorded run keeps (records beyond it are
    /// released now).
    pub fn set_capacity(&mut self, capacity: usize) {
        self.capacity = capacity;
        self.records.truncate(capacity);
        self.records.shrink_to_fit();
        // One set of stage buffers per kept step (none before a first run: `stages` is 0).
        self.stages_kept
            .truncate(capacity.checked_div(self.stages).unwrap_or(0));
        self.stages_kept.shrink_to_fit();
    }

    /// Stage records the last recorded run kept (whole steps, at most the capacity).
    #[must_use]
    pub const fn kept_stages(&self) -> usize {
        (self.steps - self.first_kept) * self.stages
    }

    /// Prepares a run of `steps` steps of `stages` stages on a tangent of `dim` entries:
    /// the last `capacity / stages` steps are kept.
    fn begin(&mut self, steps: usize, stages: usize, dim: usize) {
        let kept_steps = self.capacity.checked_div(stages).unwrap_or(0).min(steps);
        self.steps = steps;
        self.stages = stages;
        self.dim = dim;
        self.first_kept = steps - kept_steps;
        let m = kept_steps * stages;
        self.outputs.resize(m * dim, T::ZERO);
        while self.records.len() < m {
            self.records.push(R::default());
        }
        // Sized by the stepper on first use.
        while self.stages_kept.len() < kept_steps {
            self.stages_kept.push(StageBuffers::default());
        }
    }

    /// The stage values and records of step `k`, if kept.
    fn step_mut(&mut self, k: usize) -> Option<(&mut [T], &mut [R], &mut StageBuffers<T>)> {
        let j = k.checked_sub(self.first_kept)?;
        let (s, n) = (self.stages, self.dim);
        Some((
            &mut self.outputs[j * s * n..(j + 1) * s * n],
            &mut self.records[j * s..(j + 1) * s],
            &mut self.stages_kept[j],
        ))
    }
}

/// Integrates from `y0` over `grid` like
/// [`integrate_trajectory`](crate::integrate_trajectory) with
/// [`Checkpointing::StoreAll`](crate::Checkpointing::StoreAll), and keeps in `tape` the
/// stage values and field records of the last steps that fit its capacity (bitwise the same
/// trajectory).
///
/// # Panics
/// If `y0` or the field do not match the stepper's layout.
///
/// ```
/// use evogs_ode::{Checkpointing, Method, StageTape, Stepper, TimeGrid, VectorField};
/// use evogs_ode::{discrete_adjoint, discrete_adjoint_recorded, integrate_recorded};
/// use evogs_ode::{fields::LinearField, integrate_trajectory};
/// let mut f = LinearField::new(1, vec![-0.7]);
/// let mut st = Stepper::new(Method::Rk4, f.layout());
/// let grid = TimeGrid::uniform(0.0, 2.0, 10);
/// let mut tape = StageTape::new(8); // the last two RK4 steps
/// let traj = integrate_recorded(&mut f, &mut st, &grid, &[1.3], &mut tape);
/// assert_eq!(tape.kept_stages(), 8);
/// let (mut d_y0, mut d_a) = ([0.0], [0.0]);
/// discrete_adjoint_recorded(&mut f, &mut st, &traj, &mut tape, &[1.0], &mut d_y0, &mut d_a);
/// let plain = integrate_trajectory(&mut f, &mut st, &grid, &[1.3], Checkpointing::StoreAll);
/// let (mut e_y0, mut e_a) = ([0.0], [0.0]);
/// discrete_adjoint(&mut f, &mut st, &plain, &[1.0], &mut e_y0, &mut e_a);
/// assert_eq!((d_y0, d_a), (e_y0, e_a));
/// ```
pub fn integrate_recorded<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    grid: &TimeGrid<T>,
    y0: &[T],
    tape: &mut StageTape<T, F::Record>,
) -> Trajectory<T> {
    let n = grid.n_steps();
    tape.begin(n, stepper.needed_stages(), field.dim());
    let mut states = Vec::with_capacity((n + 1) * y0.len());
    states.extend_from_slice(y0);
    let mut y = y0.to_vec();
    for k in 0..n {
        let (t, h) = grid.step(k);
        match tape.step_mut(k) {
            Some((outputs, records, stages)) => {
                stepper.step_recorded(field, t, h, &mut y, outputs, records, stages);
            }
            None => stepper.step(field, t, h, &mut y),
        }
        if k + 1 < n {
            states.extend_from_slice(&y);
        }
    }
    Trajectory::store_all(*grid, y0.len(), states, y)
}

/// [`discrete_adjoint`](crate::discrete_adjoint) of a trajectory from
/// [`integrate_recorded`] with the `tape` it wrote: the kept steps' stage values and field
/// records are handed back to the stepper instead of being evaluated again (bitwise the
/// same result).
///
/// # Panics
/// If the tape was not written by a run like this trajectory's (another number of steps,
/// method or field size), or if the lengths do not match the layout and the field.
pub fn discrete_adjoint_recorded<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    trajectory: &Trajectory<T>,
    tape: &mut StageTape<T, F::Record>,
    d_final: &[T],
    d_y0: &mut [T],
    d_params: &mut [T],
) {
    let grid = trajectory.grid();
    let n = grid.n_steps();
    let stages = stepper.needed_stages();
    assert!(
        tape.steps == n && tape.stages == stages && tape.dim == field.dim(),
        "the stage tape was not recorded with this trajectory"
    );
    assert_eq!(
        d_final.len(),
        d_y0.len(),
        "d_final and d_y0 differ in length"
    );
    let lambda = d_y0;
    lambda.copy_from_slice(d_final);
    for k in (0..n).rev() {
        let (t, h) = grid.step(k);
        let y = trajectory
            .state(k)
            .expect("a recorded trajectory stores every state");
        if k < tape.first_kept {
            while tape.scratch.len() < stages {
                tape.scratch.push(F::Record::default());
            }
        }
        let StageTape {
            outputs,
            records,
            stages_kept,
            scratch,
            first_kept,
            dim,
            ..
        } = tape;
        let kept = k.checked_sub(*first_kept).map(|j| KeptStep {
            outputs: &outputs[j * stages * *dim..(j + 1) * stages * *dim],
            records: &records[j * stages..(j + 1) * stages],
            stages: &mut stages_kept[j],
        });
        stepper.step_vjp_recorded(field, t, h, y, kept, scratch, lambda, d_params);
    }
}
