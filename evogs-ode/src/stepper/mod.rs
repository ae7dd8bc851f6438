//! The explicit Runge–Kutta core: [`Stepper`] (the formulas are in its docs).

mod vjp;

use crate::chunks::{for_chunks1, for_chunks2};
use crate::{Block, BlockSpan, MAX_BLOCKS, MAX_STAGES, Method, StateLayout, Tableau, VectorField};
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::so3::exp_quat;
use evogs_math::so3_coeffs::{one_minus_cos_over_sq, theta_minus_sin_over_cube};
use evogs_math::so3_jacobians::jl_inv_mul;
use evogs_math::{Par, Quat, Real, Se3, Vec3, Vec6, se3_jacobians};

/// The per-particle block pattern with its offsets (`Copy`, for the chunk kernels).
#[derive(Clone, Copy, Debug)]
struct Pattern {
    spans: [BlockSpan; MAX_BLOCKS],
    len: usize,
    /// Ambient entries per particle.
    pa: usize,
    /// Tangent entries per particle.
    pt: usize,
}

impl Pattern {
    fn new(layout: &StateLayout) -> Self {
        let mut spans = [BlockSpan {
            block: Block::Euclidean(0),
            ambient: 0,
            tangent: 0,
        }; MAX_BLOCKS];
        let mut len = 0;
        for (slot, s) in spans.iter_mut().zip(layout.spans()) {
            *slot = s;
            len += 1;
        }
        Self {
            spans,
            len,
            pa: layout.particle_ambient_len(),
            pt: layout.particle_tangent_len(),
        }
    }

    #[inline]
    fn spans(&self) -> &[BlockSpan] {
        &self.spans[..self.len]
    }
}

/// The non-zero coefficients `(j, w_j)` of a linear combination of stages.
#[derive(Clone, Copy, Debug)]
struct Combo<T> {
    terms: [(usize, T); MAX_STAGES],
    len: usize,
}

impl<T: Real> Combo<T> {
    fn new(coeffs: impl Iterator<Item = (usize, T)>) -> Self {
        let mut terms = [(0, T::ZERO); MAX_STAGES];
        let mut len = 0;
        for (j, w) in coeffs {
            if w != T::ZERO {
                terms[len] = (j, w);
                len += 1;
            }
        }
        Self { terms, len }
    }

    /// The terms `(i, w[i])` with `keep[i]`, which must mark every non-zero weight (a
    /// continuous extension's support): a weight of a dual number can compare equal to zero
    /// (its real part) and still carry a derivative.
    fn with_kept(w: &[T], keep: &[bool]) -> Self {
        let mut terms = [(0, T::ZERO); MAX_STAGES];
        let mut len = 0;
        for (j, (&wj, &k)) in w.iter().zip(keep).enumerate() {
            debug_assert!(k || wj == T::ZERO, "a non-zero weight outside the support");
            if k {
                terms[len] = (j, wj);
                len += 1;
            }
        }
        Self { terms, len }
    }

    #[inline]
    fn terms(&self) -> &[(usize, T)] {
        &self.terms[..self.len]
    }

    /// `Σ w_j k[j·n + e]` for one entry `e`.
    #[inline]
    fn scalar(&self, k: &[T], n: usize, e: usize) -> T {
        let mut acc = T::ZERO;
        for &(j, w) in self.terms() {
            acc += w * k[j * n + e];
        }
        acc
    }

    /// `Σ w_j K_j` for the 3-vector at entry `e`.
    #[inline]
    fn vec3(&self, k: &[T], n: usize, e: usize) -> Vec3<T> {
        let mut acc = Vec3::zero();
        for &(j, w) in self.terms() {
            acc += Vec3::from_slice(&k[j * n + e..]) * w;
        }
        acc
    }

    /// `Σ w_j K_j` for the 6-vector at entry `e`.
    #[inline]
    fn vec6(&self, k: &[T], n: usize, e: usize) -> Vec6<T> {
        Vec6::new(self.vec3(k, n, e), self.vec3(k, n, e + 3))
    }
}

/// `Jl(Ω)ᵀ v = v − A·Ω×v + B·Ω×(Ω×v)` with `A = (1 − cos θ)/θ²`, `B = (θ − sin θ)/θ³`.
#[inline]
pub(crate) fn jl_tr_mul<T: Real>(big: Vec3<T>, v: Vec3<T>) -> Vec3<T> {
    let t2 = big.norm_squared();
    let c = big.cross(v);
    v - c * one_minus_cos_over_sq(t2) + big.cross(c) * theta_minus_sin_over_cube(t2)
}

/// Where the stepper takes the field value of a stage from.
pub(crate) enum StageValues<'a, T, R> {
    /// Evaluate the field.
    Eval,
    /// Evaluate the field, keeping its record of stage `i` in `records[i]` and, when given,
    /// the value in `outputs[i·n..(i+1)·n]`.
    Record {
        /// The stage values (n each), if kept.
        outputs: Option<&'a mut [T]>,
        /// The field's records, one per stage.
        records: &'a mut [R],
    },
}

impl<T: Real, R> StageValues<'_, T, R> {
    /// Writes the field value of stage `i` at `(t, x)` into `out` (n entries).
    fn value<F: VectorField<T, Record = R> + ?Sized>(
        &mut self,
        field: &mut F,
        i: usize,
        t: T,
        x: &[T],
        out: &mut [T],
    ) {
        match self {
            Self::Eval => field.eval(t, x, out),
            Self::Record { records, .. } => field.eval_recorded(t, x, out, &mut records[i]),
        }
    }

    /// Stage `i`'s slot (`n` entries) of the kept field values, if they are kept. The stage
    /// loop copies each value there (see [`Stepper::slope_from_value`]).
    fn kept(&mut self, i: usize, n: usize) -> Option<&mut [T]> {
        match self {
            Self::Record {
                outputs: Some(o), ..
            } => Some(&mut o[i * n..(i + 1) * n]),
            _ => None,
        }
    }
}

/// What one step's reverse pass reads of its stages besides the field values: the slopes
/// `Kᵢ`, the states `Xᵢ` and the increments `Ωᵢ`, in the stepper's own layout. A
/// [`StageTape`](crate::StageTape) keeps one per kept step, exchanged with the stepper's
/// buffers (no copies): [`Stepper::step_recorded`] hands the step's stages over, and
/// [`Stepper::step_vjp_recorded`] takes them back for the reverse pass instead of forming
/// them again.
#[derive(Clone, Debug, Default)]
pub(crate) struct StageBuffers<T> {
    k: Vec<T>,
    x: Vec<T>,
    omega: Vec<T>,
}

/// What a [`StageTape`](crate::StageTape) kept of one step for its reverse pass
/// ([`Stepper::step_vjp_recorded`]).
pub(crate) struct KeptStep<'a, T, R> {
    /// The stages' field values (n each).
    pub(crate) outputs: &'a [T],
    /// The field's records, one per stage.
    pub(crate) records: &'a [R],
    /// The stages' slopes, states and increments (lent back to the stepper meanwhile).
    pub(crate) stages: &'a mut StageBuffers<T>,
}

/// The reverse-pass buffers (allocated on the first [`Stepper::step_vjp`]).
#[derive(Clone, Debug, Default)]
struct AdjointBuffers<T> {
    /// Field outputs `Fᵢ` (s·n): `Kᵢ` before the `Jl⁻¹` of SO(3) blocks.
    f: Vec<T>,
    /// Per particle, the stage-slope cotangents `K̄₀ … K̄ₛ₋₁` and the cotangent `Ω̄` of the
    /// current stage's increment, one tangent each: `(s + 1)·pt` entries per particle, so
    /// one pass over the particles reaches all of a particle's.
    kb: Vec<T>,
    /// Cotangent handed to the field VJP (n).
    w: Vec<T>,
    /// Stage-state cotangent `X̄ᵢ` returned by the field VJP (n).
    xbar: Vec<T>,
}

/// An explicit Runge–Kutta stepper (Euclidean blocks) that is simultaneously the
/// left-trivialised RKMK method with the same tableau (SO(3) and SE(3) blocks).
///
/// Conventions: states are ambient (`StateLayout::ambient_len`, SO(3) blocks as unit
/// quaternions w, x, y, z, SE(3) blocks as the quaternion then the translation);
/// derivatives and cotangents are tangent (`tangent_len`, SO(3) blocks as world-frame
/// 3-vectors, SE(3) blocks as world-frame twists (ρ, φ), cotangents with respect to the left
/// perturbations `R ↦ Exp(δ)·R` and `T ↦ Exp(δ)·T`).
///
/// For a step from `(tₙ, yₙ)` with step `h` (negative backward in time), stage `i` is
///
/// ```text
/// Euclidean block:  Ωᵢ = h Σ_{j<i} a_ij Kⱼ,   Xᵢ = yₙ + Ωᵢ,         Kᵢ = f(tₙ + cᵢh, Xᵢ)
/// SO(3) block:      Ωᵢ = h Σ_{j<i} a_ij Kⱼ,   Rᵢ = Exp(Ωᵢ)·Rₙ,      ωᵢ = f(tₙ + cᵢh, Xᵢ)
///                                                                  Kᵢ = Jl⁻¹(Ωᵢ)·ωᵢ
/// SE(3) block:      the SO(3) rule with Exp, Jl⁻¹ of SE(3) (Ωᵢ, Kᵢ twists (ρ, φ)):
///                   Tᵢ = Exp(Ωᵢ)·Tₙ,  Kᵢ = Jl⁻¹(Ωᵢ)·ξᵢ,  T_{n+1} = Exp(h Σ bᵢKᵢ)·Tₙ
/// update:           y_{n+1} = yₙ + h Σ bᵢKᵢ;   R_{n+1} = Exp(h Σ bᵢKᵢ)·Rₙ, then |q| ← 1
/// ```
///
/// The SO(3) rule is the left-trivialised Runge–Kutta–Munthe-Kaas method: writing
/// `R(t) = Exp(Ω(t))·Rₙ` for a world-frame rate (`R' = ω̂R`) gives the vector-space ODE
/// `Ω' = dexp⁻¹_Ω(ω) = Jl⁻¹(Ω)·ω`, to which the tableau is applied for one step. On SO(3)
/// `Jl⁻¹` has the closed form `I − ½Ω̂ + D(θ)Ω̂²` (`docs/lie-groups.md` §4), so no commutator
/// series is truncated and the method keeps the tableau's order (HLW Thm IV.8.5). With the
/// Euler tableau it is Lie–Euler `R ← Exp(hω)R`; with classical RK4 it is RKMK4. Both are
/// exact (to rounding) for a constant rate. On SE(3) the same holds with the world twist
/// (`Ṫ = ξ̂T`) and the closed-form SE(3) `Jl⁻¹` ([`evogs_math::se3_jacobians`]), so the
/// methods keep their orders on SE(3) and on products with vector spaces.
///
/// An FSAL tableau ([`Tableau::is_fsal`], the adaptive pairs) takes its last stage at the
/// new state exactly as the update forms it (rotations renormalised), so that stage is
/// bitwise `f(t_{n+1}, y_{n+1})`; [`step`](Self::step) evaluates only the stages the update
/// uses (up to the last non-zero `bᵢ`).
///
/// The stepper owns every stage buffer: forward steps allocate nothing. The buffers of
/// the reverse pass ([`Stepper::step_vjp`]) are allocated on its first call and reused.
///
/// ```
/// use evogs_ode::{Method, Stepper, TimeGrid, VectorField, integrate, fields::LinearField};
/// // y' = −y from y(0) = 1 to t = 1 with 8 RK4 steps.
/// let mut field = LinearField::new(1, vec![-1.0]);
/// let mut stepper = Stepper::new(Method::Rk4, field.layout());
/// let mut y = [1.0];
/// integrate(&mut field, &mut stepper, &TimeGrid::uniform(0.0, 1.0, 8), &mut y);
/// assert!((y[0] - (-1.0_f64).exp()).abs() < 1e-6);
/// ```
#[derive(Clone, Debug)]
pub struct Stepper<T> {
    tableau: Tableau,
    s: usize,
    a: [[T; MAX_STAGES]; MAX_STAGES],
    c: [T; MAX_STAGES],
    b: [T; MAX_STAGES],
    layout: StateLayout,
    pat: Pattern,
    count: usize,
    /// Tangent length.
    n: usize,
    euclidean: bool,
    /// The tableau is FSAL ([`Tableau::is_fsal`]): its last stage is taken at the new state.
    fsal: bool,
    par: Par,
    /// Stage slopes `Kᵢ` (s·n).
    k: Vec<T>,
    /// Stage states `Xᵢ` (s·ambient; stage 0's is unused: `X₀ = yₙ`). Every stage keeps
    /// its own, so the reverse pass reads them instead of forming them again.
    x: Vec<T>,
    /// Stage increments `Ωᵢ` (s·n; SO(3) and SE(3) entries; stage 0's is unused: `Ω₀ = 0`).
    omega: Vec<T>,
    /// FSAL tableaux on non-Euclidean layouts: the last stage's field value `f(t_{n+1},
    /// y_{n+1})` before `Jl⁻¹` (the next step's `K₀`).
    fsal_f: Vec<T>,
    adj: AdjointBuffers<T>,
}

impl<T: Real> Stepper<T> {
    /// A stepper for a built-in method on states with this layout.
    #[must_use]
    pub fn new(method: Method, layout: StateLayout) -> Self {
        Self::with_tableau(method.tableau(), layout)
    }

    /// A stepper driven by any explicit tableau (e.g. for order-verification studies).
    #[must_use]
    pub fn with_tableau(tableau: Tableau, layout: StateLayout) -> Self {
        let s = tableau.stages();
        let mut a = [[T::ZERO; MAX_STAGES]; MAX_STAGES];
        let mut c = [T::ZERO; MAX_STAGES];
        let mut b = [T::ZERO; MAX_STAGES];
        for i in 0..s {
            c[i] = T::from_f64(tableau.c(i).to_f64());
            b[i] = T::from_f64(tableau.b(i).to_f64());
            for j in 0..i {
                a[i][j] = T::from_f64(tableau.a(i, j).to_f64());
            }
        }
        let n = layout.tangent_len();
        Self {
            tableau,
            s,
            a,
            c,
            b,
            layout,
            pat: Pattern::new(&layout),
            count: layout.count(),
            n,
            euclidean: layout.is_euclidean(),
            fsal: tableau.is_fsal(),
            par: Par::Seq,
            k: vec![T::ZERO; s * n],
            x: vec![T::ZERO; s * layout.ambient_len()],
            omega: vec![T::ZERO; s * n],
            fsal_f: if tableau.is_fsal() && !layout.is_euclidean() {
                vec![T::ZERO; n]
            } else {
                Vec::new()
            },
            adj: AdjointBuffers::default(),
        }
    }

    /// Sets how the per-particle block updates may use threads (results are bitwise
    /// identical either way; the field's own evaluation is not affected).
    #[must_use]
    pub const fn with_par(mut self, par: Par) -> Self {
        self.par = par;
        self
    }

    /// Changes the parallelism setting in place.
    pub const fn set_par(&mut self, par: Par) {
        self.par = par;
    }

    /// The parallelism setting.
    #[must_use]
    pub const fn par(&self) -> Par {
        self.par
    }

    /// The tableau.
    #[must_use]
    pub const fn tableau(&self) -> &Tableau {
        &self.tableau
    }

    /// The state layout.
    #[must_use]
    pub const fn layout(&self) -> &StateLayout {
        &self.layout
    }

    /// One step from `(t, y)` with step `h`, in place (`y` ambient).
    ///
    /// # Panics
    /// If `y` or the field do not match the stepper's layout.
    pub fn step<F: VectorField<T> + ?Sized>(&mut self, field: &mut F, t: T, h: T, y: &mut [T]) {
        self.check(field, y);
        self.eval_stages(field, t, h, y, None, self.needed_stages());
        self.update(h, y);
    }

    /// The stages the update uses: up to the last non-zero weight `bᵢ` (an FSAL tableau's
    /// last stage only serves error estimates and dense output).
    pub(crate) fn needed_stages(&self) -> usize {
        (0..self.s)
            .rev()
            .find(|&i| self.b[i] != T::ZERO)
            .map_or(1, |i| i + 1)
    }

    /// Stages `0..upto` from `(t, y)` into `k`; `K₀` is copied from `k0` when given (the
    /// previous step's last stage of an FSAL pair, `f(t, y)`).
    pub(crate) fn eval_stages<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y: &[T],
        k0: Option<&[T]>,
        upto: usize,
    ) {
        self.eval_stages_from(field, t, h, y, k0, upto, &mut StageValues::Eval);
    }

    /// [`eval_stages`](Self::eval_stages) with the field values of the stages taken from
    /// `values` (evaluated, evaluated and recorded, or replayed from a record).
    pub(crate) fn eval_stages_from<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y: &[T],
        k0: Option<&[T]>,
        upto: usize,
        values: &mut StageValues<'_, T, F::Record>,
    ) {
        let (n, na) = (self.n, y.len());
        for i in 0..upto {
            let ti = t + self.c[i] * h;
            if i == 0 {
                match k0 {
                    Some(k0) => self.k[..n].copy_from_slice(k0),
                    None => {
                        values.value(field, 0, ti, y, &mut self.k[..n]);
                        self.slope_from_value(0, values.kept(0, n));
                    }
                }
            } else {
                self.stage_point(i, h, y);
                let xi = &self.x[i * na..(i + 1) * na];
                values.value(field, i, ti, xi, &mut self.k[i * n..(i + 1) * n]);
                if i + 1 == self.s && !self.fsal_f.is_empty() {
                    self.fsal_f.copy_from_slice(&self.k[i * n..(i + 1) * n]);
                }
                self.slope_from_value(i, values.kept(i, n));
            }
        }
    }

    /// Turns the field value in stage `i`'s slot of `k` into the stage's slope
    /// ([`dexp_inv`](Self::dexp_inv); stage 0's is its value), first copying the value into `keep` when given, in the same pass
    /// over the particles (one pass on the pool, not a serial copy and then a pass).
    fn slope_from_value(&mut self, i: usize, keep: Option<&mut [T]>) {
        let Some(keep) = keep else {
            if i > 0 {
                self.dexp_inv(i);
            }
            return;
        };
        let (n, pt) = (self.n, self.pat.pt);
        let ki = &mut self.k[i * n..(i + 1) * n];
        if i == 0 || self.euclidean {
            // Kᵢ is the field value itself.
            let ki = &*ki;
            for_chunks1(self.par, self.count, keep, pt, |p0, np, kc| {
                kc.copy_from_slice(&ki[p0 * pt..(p0 + np) * pt]);
            });
            return;
        }
        let (pat, omega) = (self.pat, &self.omega[i * n..(i + 1) * n]);
        for_chunks2(
            self.par,
            self.count,
            ki,
            pt,
            keep,
            pt,
            |p0, np, kc, keep| {
                keep.copy_from_slice(kc);
                dexp_inv_particles(pat, omega, p0, np, kc);
            },
        );
    }

    /// One [`step`](Self::step) that also keeps, per stage `i`, the field value in
    /// `outputs[i·n..(i+1)·n]` and the field's record in `records[i]`, and the stages'
    /// slopes, states and increments in `stages` (for
    /// [`step_vjp_recorded`](Self::step_vjp_recorded)). The stepper's stage buffers then
    /// hold what `stages` held: [`slopes`](Self::slopes) is not this step's.
    pub(crate) fn step_recorded<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y: &mut [T],
        outputs: &mut [T],
        records: &mut [F::Record],
        stages: &mut StageBuffers<T>,
    ) {
        self.check(field, y);
        let mut values = StageValues::Record {
            outputs: Some(outputs),
            records,
        };
        self.eval_stages_from(field, t, h, y, None, self.needed_stages(), &mut values);
        self.update(h, y);
        self.exchange_stages(stages);
    }

    /// Exchanges the stage slopes, states and increments with `kept` (sized like the
    /// stepper's on first use): after a step they go to `kept`; before its reverse pass they
    /// come back. The stepper's own then hold whatever `kept` held.
    pub(crate) fn exchange_stages(&mut self, kept: &mut StageBuffers<T>) {
        if kept.k.len() != self.k.len()
            || kept.x.len() != self.x.len()
            || kept.omega.len() != self.omega.len()
        {
            *kept = StageBuffers {
                k: vec![T::ZERO; self.k.len()],
                x: vec![T::ZERO; self.x.len()],
                omega: vec![T::ZERO; self.omega.len()],
            };
        }
        core::mem::swap(&mut self.k, &mut kept.k);
        core::mem::swap(&mut self.x, &mut kept.x);
        core::mem::swap(&mut self.omega, &mut kept.omega);
    }

    /// After all stages of an FSAL tableau: `f(t_{n+1}, y_{n+1})`, the next step's `K₀`.
    pub(crate) fn fsal_slope(&self) -> &[T] {
        if self.fsal_f.is_empty() {
            &self.k[(self.s - 1) * self.n..]
        } else {
            &self.fsal_f
        }
    }

    /// `Xᵢ` and `Ωᵢ` of stage `i > 0`, into the stage's own slots. The last stage of an FSAL tableau is taken at the
    /// new state `yₙ ⊕ h Σ bⱼKⱼ` exactly as the update forms it (on Euclidean entries that
    /// is bitwise `Xᵢ`; rotations are renormalised), so that it is bitwise `f(t_{n+1},
    /// y_{n+1})`, the next step's first stage.
    fn stage_point(&mut self, i: usize, h: T, y: &[T]) {
        self.stage_state(i, h, y);
        if self.fsal && !self.euclidean && i + 1 == self.s {
            let combo = Combo::new((0..self.s).map(|j| (j, self.b[j])));
            let mut x = core::mem::take(&mut self.x);
            let xi = &mut x[i * y.len()..(i + 1) * y.len()];
            xi.copy_from_slice(y);
            self.apply(&combo, h, xi);
            self.x = x;
        }
    }

    /// `y ← y ⊕ h Σ wᵢKᵢ` with the stage slopes of the last step (`w`: one weight per
    /// stage): the update with other weights, e.g. a continuous extension.
    pub(crate) fn advance(&self, w: &[T], h: T, y: &mut [T]) {
        let combo = Combo::new(w.iter().copied().enumerate());
        self.apply(&combo, h, y);
    }

    /// [`advance`](Self::advance) keeping the terms marked in `keep` even at weight zero
    /// (continuous extensions in dual numbers: `b₇(1) = 0` but `b₇'(1) = 1`).
    pub(crate) fn advance_kept(&self, w: &[T], keep: &[bool], h: T, y: &mut [T]) {
        let combo = Combo::with_kept(w, keep);
        self.apply(&combo, h, y);
    }

    /// The stage slopes `Kᵢ` of the last step (`s` tangent vectors, stage-major).
    pub(crate) fn slopes(&self) -> &[T] {
        &self.k
    }

    /// The weights `bᵢ` as floats (`s` entries).
    pub(crate) fn weights(&self) -> &[T] {
        &self.b[..self.s]
    }

    fn check<F: VectorField<T> + ?Sized>(&self, field: &F, y: &[T]) {
        assert_eq!(
            y.len(),
            self.layout.ambient_len(),
            "state length differs from the layout"
        );
        assert_eq!(
            field.dim(),
            self.n,
            "field dimension differs from the layout"
        );
        debug_assert!(
            field.layout() == self.layout,
            "the field's layout differs from the stepper's"
        );
    }

    /// Writes `Xᵢ` and `Ωᵢ` (SO(3) and SE(3) entries) into stage `i`'s slots of `x` and
    /// `omega`, from `yₙ` and `K_{j<i}`.
    fn stage_state(&mut self, i: usize, h: T, y: &[T]) {
        let combo = Combo::new((0..i).map(|j| (j, self.a[i][j])));
        let Self {
            pat,
            n,
            par,
            count,
            euclidean,
            k,
            x,
            omega,
            ..
        } = self;
        let (pat, n, k) = (*pat, *n, &*k);
        let x = &mut x[i * y.len()..(i + 1) * y.len()];
        let omega = &mut omega[i * n..(i + 1) * n];
        if *euclidean {
            // Ambient and tangent coordinates coincide: one flat loop per chunk.
            for_chunks1(*par, *count, x, pat.pa, |p0, np, xc| {
                let lo = p0 * pat.pa;
                for (e, (xe, ye)) in xc.iter_mut().zip(&y[lo..lo + np * pat.pa]).enumerate() {
                    *xe = *ye + h * combo.scalar(k, n, lo + e);
                }
            });
            return;
        }
        for_chunks2(*par, *count, x, pat.pa, omega, pat.pt, |p0, np, xc, oc| {
            for p in 0..np {
                let ya = &y[(p0 + p) * pat.pa..];
                let xa = &mut xc[p * pat.pa..(p + 1) * pat.pa];
                let oa = &mut oc[p * pat.pt..(p + 1) * pat.pt];
                let gt = (p0 + p) * pat.pt;
                for sp in pat.spans() {
                    match sp.block {
                        Block::Euclidean(m) => {
                            for e in 0..m {
                                let inc = combo.scalar(k, n, gt + sp.tangent + e);
                                xa[sp.ambient + e] = ya[sp.ambient + e] + h * inc;
                            }
                        }
                        Block::So3 => {
                            let big = combo.vec3(k, n, gt + sp.tangent) * h;
                            big.write_to(&mut oa[sp.tangent..]);
                            let q = Quat::from_slice(&ya[sp.ambient..]);
                            exp_quat(big).mul_quat(q).write_to(&mut xa[sp.ambient..]);
                        }
                        Block::Se3 => {
                            let big = combo.vec6(k, n, gt + sp.tangent) * h;
                            big.write_to(&mut oa[sp.tangent..]);
                            let t = Se3::exp(big) * Se3::from_slice(&ya[sp.ambient..]);
                            t.write_to(&mut xa[sp.ambient..]);
                        }
                    }
                }
            }
        });
    }

    /// `Kᵢ ← Jl⁻¹(Ωᵢ)·Kᵢ` on SO(3) and SE(3) entries (stage `i > 0`; `Ω₀ = 0` is the
    /// identity).
    fn dexp_inv(&mut self, i: usize) {
        if self.euclidean {
            return;
        }
        let Self {
            pat,
            n,
            par,
            count,
            k,
            omega,
            ..
        } = self;
        let (pat, omega) = (*pat, &omega[i * *n..(i + 1) * *n]);
        let ki = &mut k[i * *n..(i + 1) * *n];
        for_chunks1(*par, *count, ki, pat.pt, |p0, np, kc| {
            dexp_inv_particles(pat, omega, p0, np, kc);
        });
    }

    /// `y ← yₙ + h Σ bᵢKᵢ` (Euclidean), `R ← Exp(h Σ bᵢKᵢ)·R` then `|q| ← 1` (SO(3)),
    /// `T ← Exp(h Σ bᵢKᵢ)·T` then `|q| ← 1` (SE(3)).
    fn update(&mut self, h: T, y: &mut [T]) {
        let combo = Combo::new((0..self.s).map(|i| (i, self.b[i])));
        self.apply(&combo, h, y);
    }

    /// `y ← y + h Σ wᵢKᵢ` (Euclidean), `R ← Exp(h Σ wᵢKᵢ)·R` then `|q| ← 1` (SO(3)).
    fn apply(&self, combo: &Combo<T>, h: T, y: &mut [T]) {
        let (pat, n, k) = (self.pat, self.n, &self.k);
        if self.euclidean {
            for_chunks1(self.par, self.count, y, pat.pa, |p0, _, yc| {
                let lo = p0 * pat.pa;
                for (e, ye) in yc.iter_mut().enumerate() {
                    *ye += h * combo.scalar(k, n, lo + e);
                }
            });
            return;
        }
        for_chunks1(self.par, self.count, y, pat.pa, |p0, np, yc| {
            for p in 0..np {
                let ya = &mut yc[p * pat.pa..(p + 1) * pat.pa];
                let gt = (p0 + p) * pat.pt;
                for sp in pat.spans() {
                    match sp.block {
                        Block::Euclidean(m) => {
                            for e in 0..m {
                                ya[sp.ambient + e] += h * combo.scalar(k, n, gt + sp.tangent + e);
                            }
                        }
                        Block::So3 => {
                            let big = combo.vec3(k, n, gt + sp.tangent) * h;
                            let q = Quat::from_slice(&ya[sp.ambient..]);
                            exp_quat(big)
                                .mul_quat(q)
                                .normalize()
                                .write_to(&mut ya[sp.ambient..]);
                        }
                        Block::Se3 => {
                            let big = combo.vec6(k, n, gt + sp.tangent) * h;
                            let t = Se3::exp(big) * Se3::from_slice(&ya[sp.ambient..]);
                            t.renormalize().write_to(&mut ya[sp.ambient..]);
                        }
                    }
                }
            }
        });
    }
}

/// `K ← Jl⁻¹(Ω)·K` on the SO(3) and SE(3) entries of particles `p0..p0 + np`, whose slopes
/// are `kc` (the chunk's own) and whose increments are in `omega` (all particles).
fn dexp_inv_particles<T: Real>(pat: Pattern, omega: &[T], p0: usize, np: usize, kc: &mut [T]) {
    for p in 0..np {
        let gt = (p0 + p) * pat.pt;
        for sp in pat.spans() {
            let e = p * pat.pt + sp.tangent;
            match sp.block {
                Block::Euclidean(_) => {}
                Block::So3 => {
                    let big = Vec3::from_slice(&omega[gt + sp.tangent..]);
                    jl_inv_mul(big, Vec3::from_slice(&kc[e..])).write_to(&mut kc[e..]);
                }
                Block::Se3 => {
                    let big = Vec6::from_slice(&omega[gt + sp.tangent..]);
                    se3_jacobians::jl_inv_mul(big, Vec6::from_slice(&kc[e..]))
                        .write_to(&mut kc[e..]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Stepper, jl_tr_mul};
    use crate::fields::LinearField;
    use crate::{Block, Method, StateLayout};
    use evogs_math::Vec3;
    use evogs_math::so3_jacobians::left_jacobian;

    #[test]
    #[should_panic(expected = "state length differs from the layout")]
    fn a_state_of_another_length_is_refused() {
        let mut f = LinearField::new(2, alloc::vec![0.0; 4]);
        let mut st = Stepper::new(Method::Rk4, StateLayout::euclidean(2));
        st.step(&mut f, 0.0, 0.1, &mut [1.0, 2.0, 3.0]);
    }

    #[test]
    #[should_panic(expected = "field dimension differs from the layout")]
    fn a_field_of_another_dimension_is_refused() {
        let mut f = LinearField::new(3, alloc::vec![0.0; 9]);
        let mut st = Stepper::new(Method::Rk4, StateLayout::euclidean(2));
        st.step(&mut f, 0.0, 0.1, &mut [1.0, 2.0]);
    }

    #[test]
    #[should_panic(expected = "the field's layout differs from the stepper's")]
    #[cfg(debug_assertions)]
    fn a_field_of_another_layout_is_refused() {
        let mut f = LinearField::new(6, alloc::vec![0.0; 36]);
        let layout = StateLayout::particles(&[Block::Euclidean(3)], 2);
        let mut st = Stepper::new(Method::Rk4, layout);
        st.step(&mut f, 0.0, 0.1, &mut [0.0; 6]);
    }

    #[test]
    fn jl_transpose_product_matches_the_matrix() {
        let v = Vec3::new(0.3, -1.2, 0.8);
        for big in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1e-9, 2e-9, -1e-9),
            Vec3::new(0.01, -0.02, 0.03),
            Vec3::new(0.7, -1.9, 1.1),
        ] {
            let want = left_jacobian(big).tr_mul_vec(v);
            assert!((jl_tr_mul(big, v) - want).norm() < 1e-15, "Jlᵀv at {big:?}");
        }
    }
}
