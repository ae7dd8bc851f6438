//! Fixed-grid integration: [`integrate`] in place, and [`integrate_trajectory`], which keeps
//! checkpoints for the discrete adjoint and for restarts.

use crate::{Stepper, TimeGrid, VectorField};
use alloc::vec::Vec;
use evogs_math::Real;

/// Which states an [`integrate_trajectory`] run keeps for the reverse pass.
///
/// Both policies give **bitwise identical** gradients: the reverse pass of `Every(k)`
/// recomputes each segment forward from its checkpoint with the same step function.
///
/// | policy | states stored | extra forward steps in the reverse pass |
/// |---|---|---|
/// | `StoreAll` | N + 1 | none |
/// | `Every(k)` | ⌈N/k⌉ + 1, plus a k-state segment buffer | about N (one more forward pass) |
///
/// With `k ≈ √N` ([`Checkpointing::sqrt`]) memory is about `2√N` states.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Checkpointing {
    /// Store every state.
    #[default]
    StoreAll,
    /// Store every k-th state (k ≥ 1) and the final state.
    Every(usize),
}

impl Checkpointing {
    /// `Every(⌈√n⌉)` for `n` steps (at least 1).
    #[must_use]
    pub fn sqrt(n_steps: usize) -> Self {
        let mut k = 1;
        while k * k < n_steps {
            k += 1;
        }
        Self::Every(k)
    }

    /// The checkpoint interval (1 for `StoreAll`).
    ///
    /// # Panics
    /// For `Every(0)`.
    #[must_use]
    pub fn interval(self) -> usize {
        match self {
            Self::StoreAll => 1,
            Self::Every(k) => {
                assert!(k > 0, "checkpoint interval must be at least 1");
                k
            }
        }
    }
}

/// Integrates `y` in place over every step of `grid`.
///
/// # Panics
/// If `y` or the field do not match the stepper's layout.
pub fn integrate<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    grid: &TimeGrid<T>,
    y: &mut [T],
) {
    integrate_steps(field, stepper, grid, 0, grid.n_steps(), y);
}

/// Integrates `y` in place over steps `first..last` of `grid` (from `t_first` to
/// `t_last`): the building block of restarts and of checkpoint recomputation.
///
/// A restart (a waypoint of the EvoGS model, or resuming from a stored checkpoint) is an
/// integration from any `(t, state)`: either the remaining steps of the same grid from
/// `trajectory.state(k)` (bitwise the same as the uninterrupted run), or [`integrate`] over
/// a new grid starting at `trajectory.grid().time(k)`.
///
/// # Panics
/// If `first > last` or `last > grid.n_steps()`, or on a layout mismatch.
pub fn integrate_steps<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    grid: &TimeGrid<T>,
    first: usize,
    last: usize,
    y: &mut [T],
) {
    assert!(
        first <= last && last <= grid.n_steps(),
        "step range {first}..{last} outside the grid"
    );
    for k in first..last {
        let (t, h) = grid.step(k);
        stepper.step(field, t, h, y);
    }
}

/// A forward solution with its checkpoints: what the discrete adjoint needs.
///
/// States are ambient vectors. `state(k)` is `Some` for every stored grid index (all of
/// them with `StoreAll`, multiples of k with `Every(k)`) and for the final index `N`.
#[derive(Clone, Debug)]
pub struct Trajectory<T> {
    grid: TimeGrid<T>,
    checkpointing: Checkpointing,
    len: usize,
    /// Stored states, `len` entries each, for grid indices 0, k, 2k, … < N (and 0).
    states: Vec<T>,
    final_state: Vec<T>,
}

impl<T: Real> Trajectory<T> {
    /// The grid.
    #[must_use]
    pub const fn grid(&self) -> &TimeGrid<T> {
        &self.grid
    }

    /// The checkpointing policy.
    #[must_use]
    pub const fn checkpointing(&self) -> Checkpointing {
        self.checkpointing
    }

    /// Length of one state (ambient).
    #[must_use]
    pub const fn state_len(&self) -> usize {
        self.len
    }

    /// The initial state `y(t0)`.
    #[must_use]
    pub fn initial_state(&self) -> &[T] {
        &self.states[..self.len]
    }

    /// The final state `y(t1)`.
    #[must_use]
    pub fn final_state(&self) -> &[T] {
        &self.final_state
    }

    /// The state at grid index `k` if it was stored (`k = N` always is).
    #[must_use]
    pub fn state(&self, k: usize) -> Option<&[T]> {
        let n = self.grid.n_steps();
        if k == n {
            return Some(&self.final_state);
        }
        let every = self.checkpointing.interval();
        if k > n || !k.is_multiple_of(every) {
            return None;
        }
        let slot = k / every;
        Some(&self.states[slot * self.len..(slot + 1) * self.len])
    }

    /// Number of states held (checkpoints plus the final state): the memory cost in
    /// states.
    #[must_use]
    pub fn stored_states(&self) -> usize {
        self.states.len() / self.len.max(1) + 1
    }
}

impl<T> Trajectory<T> {
    /// A `StoreAll` trajectory over `grid` from its states (`len` entries each, grid
    /// indices `0..N`) and the final state.
    pub(crate) const fn store_all(
        grid: TimeGrid<T>,
        len: usize,
        states: Vec<T>,
        final_state: Vec<T>,
    ) -> Self {
        Self {
            grid,
            checkpointing: Checkpointing::StoreAll,
            len,
            states,
            final_state,
        }
    }
}

/// Integrates from `y0` over `grid`, keeping checkpoints according to `checkpointing`.
///
/// # Panics
/// If `y0` or the field do not match the stepper's layout, or for `Every(0)`.
pub fn integrate_trajectory<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    grid: &TimeGrid<T>,
    y0: &[T],
    checkpointing: Checkpointing,
) -> Trajectory<T> {
    let len = y0.len();
    let n = grid.n_steps();
    let every = checkpointing.interval();
    let mut states = Vec::with_capacity((n / every + 1) * len);
    states.extend_from_slice(y0);
    let mut y = y0.to_vec();
    for k in 0..n {
        let (t, h) = grid.step(k);
        stepper.step(field, t, h, &mut y);
        if (k + 1).is_multiple_of(every) && k + 1 < n {
            states.extend_from_slice(&y);
        }
    }
    Trajectory {
        grid: *grid,
        checkpointing,
        len,
        states,
        final_state: y,
    }
}

#[cfg(test)]
mod tests {
    use super::{Checkpointing, Trajectory};
    use crate::TimeGrid;
    use alloc::vec;

    #[test]
    fn a_trajectory_hands_back_the_states_it_holds_and_no_others() {
        // Four steps of a two-entry state: states 0..4 and the final one.
        let states = vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5];
        let grid = TimeGrid::uniform(0.0_f64, 1.0, 4);
        let t = Trajectory::store_all(grid, 2, states, vec![4.0, 4.5]);
        assert_eq!(t.initial_state(), [0.0, 0.5], "y(t0)");
        assert_eq!(t.final_state(), [4.0, 4.5], "y(t1)");
        assert_eq!(t.state(2), Some(&[2.0, 2.5][..]), "index 2");
        assert_eq!(
            t.state(4),
            Some(&[4.0, 4.5][..]),
            "index N: the final state"
        );
        for k in [5, 6, 100] {
            assert_eq!(t.state(k), None, "index {k} beyond N");
        }
        assert_eq!(t.stored_states(), 5, "four checkpoints and the final state");
    }

    #[test]
    fn sqrt_checkpointing_is_the_ceiling_of_the_square_root() {
        for (n, k) in [
            (0, 1),
            (1, 1),
            (2, 2),
            (4, 2),
            (5, 3),
            (16, 4),
            (17, 5),
            (1_000_000, 1000),
        ] {
            assert_eq!(Checkpointing::sqrt(n), Checkpointing::Every(k), "{n} steps");
        }
        assert_eq!(Checkpointing::StoreAll.interval(), 1, "every state");
        assert_eq!(Checkpointing::Every(7).interval(), 7, "every 7th");
    }
}
