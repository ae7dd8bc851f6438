//! The exact VJP of one step: [`Stepper::step_vjp`] (formulas in its docs).

use super::{Combo, KeptStep, StageValues, Stepper, jl_tr_mul};
use crate::chunks::{for_chunks2, for_chunks4};
use crate::{Block, VectorField};
use alloc::vec;
use evogs_math::so3::exp_quat;
use evogs_math::so3_jacobians::jl_inv_mul_vjp;
use evogs_math::{Real, Se3, Vec3, Vec6, se3_jacobians};

impl<T: Real> Stepper<T> {
    /// The exact VJP of one [`step`](Self::step) from `(t, y_n)` with step `h`.
    ///
    /// - `lambda` (tangent): on entry the cotangent at `y_{n+1}`, on exit the cotangent at
    ///   `y_n` (overwritten in place);
    /// - `d_params`: the field-parameter gradient of this step is **added**.
    ///
    /// The stages are recomputed from `y_n` (s field evaluations and s field VJPs). The
    /// first call allocates the reverse-pass buffers; later calls allocate nothing.
    ///
    /// The transpose of the linearised step, processing the stages in reverse
    /// (`docs/integrators.md` §4). With λ the cotangent at `y_{n+1}` (tangent coordinates):
    ///
    /// ```text
    /// update      Euclidean:  Ω̄ = λ                        (λₙ starts as λ)
    ///             SO(3):      Ω̄ = Jl(Ω)ᵀλ,  λₙ starts as Exp(Ω)ᵀλ      (Ω = h Σ bᵢKᵢ)
    ///             SE(3):      Ω̄ = Jl(Ω)ᵀλ,  λₙ starts as Ad(Exp(Ω))ᵀλ
    ///             K̄ᵢ = h bᵢ Ω̄ for every stage
    /// stage i = s..1:
    ///   field     Euclidean:  ω̄ᵢ = K̄ᵢ
    ///             SO(3), SE(3): (Ω̄ᵢ, ω̄ᵢ) = VJP of Jl⁻¹(Ωᵢ)·ωᵢ at K̄ᵢ
    ///             X̄ᵢ = (∂f/∂X)ᵀ ω̄ᵢ  and  θ̄ += (∂f/∂θ)ᵀ ω̄ᵢ   (one field VJP at (tₙ + cᵢh, Xᵢ))
    ///   state     Euclidean:  λₙ += X̄ᵢ,            Ω̄ᵢ = X̄ᵢ
    ///             SO(3):      λₙ += Exp(Ωᵢ)ᵀX̄ᵢ,    Ω̄ᵢ += Jl(Ωᵢ)ᵀX̄ᵢ
    ///             SE(3):      λₙ += Ad(Exp(Ωᵢ))ᵀX̄ᵢ, Ω̄ᵢ += Jl(Ωᵢ)ᵀX̄ᵢ
    ///   coupling  K̄ⱼ += h a_ij Ω̄ᵢ  for j < i
    /// ```
    ///
    /// The SO(3) rules come from linearising `R' = Exp(Ω)·R` with left perturbations:
    /// `Exp(Ω + dΩ)·Exp(δ)·R = Exp(Jl(Ω)dΩ + Exp(Ω)δ)·Exp(Ω)·R + O(2)`, using
    /// `Exp(Ω + dΩ) ≈ Exp(Jl(Ω)dΩ)·Exp(Ω)` and `Exp(Ω)·Exp(δ)·Exp(Ω)ᵀ = Exp(Exp(Ω)δ)`. On SE(3)
    /// the same linearisation holds with the SE(3) Jacobian and
    /// `Exp(Ω)·Exp(δ)·Exp(Ω)⁻¹ = Exp(Ad(Exp(Ω))δ)` (`docs/se3.md`).
    ///
    /// The stage values are recomputed from the stored `yₙ` with the same code as the
    /// forward step (bitwise the same stages), so only states need to be stored.
    ///
    /// # Panics
    /// If `y_n`, `lambda` or `d_params` do not match the layout and the field.
    ///
    /// ```
    /// use evogs_math::diff::{GradCheck, central_gradient};
    /// use evogs_ode::{Method, Stepper, VectorField, problems::Logistic};
    /// // One RK4 step of y' = r y (1 − y): gradient of y₁ with respect to (y₀, r).
    /// let (t, h, y0, r) = (0.2, 0.5, 0.3, 1.4);
    /// let mut f = Logistic { rate: r, ..Default::default() };
    /// let mut st = Stepper::new(Method::Rk4, f.layout());
    /// let (mut lambda, mut d_r) = ([1.0], [0.0]);
    /// st.step_vjp(&mut f, t, h, &[y0], &mut lambda, &mut d_r);
    /// let mut x = [y0, r];
    /// let mut num = [0.0; 2];
    /// central_gradient(
    ///     |v: &[f64]| {
    ///         let mut g = Logistic { rate: v[1], ..Default::default() };
    ///         let mut y = [v[0]];
    ///         Stepper::new(Method::Rk4, g.layout()).step(&mut g, t, h, &mut y);
    ///         y[0]
    ///     },
    ///     &mut x,
    ///     &mut num,
    /// );
    /// GradCheck::new(1e-10, 1e-8).check(&[lambda[0], d_r[0]], &num).assert_passed("step_vjp");
    /// ```
    pub fn step_vjp<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y_n: &[T],
        lambda: &mut [T],
        d_params: &mut [T],
    ) {
        self.check_vjp(field, y_n, lambda, d_params);
        let upto = self.needed_stages();
        self.ensure_adjoint_buffers();
        self.recompute_stages(field, t, h, y_n, upto, &mut StageValues::Eval);
        let combo = Combo::new((0..self.s).map(|i| (i, self.b[i])));
        self.update_pass(&combo, h, lambda, true);
        self.vjp_stages(field, t, h, y_n, upto, lambda, d_params);
    }

    /// The argument checks of a step's VJP: the state, the cotangent and the parameter
    /// gradient fit the layout and the field.
    fn check_vjp<F: VectorField<T> + ?Sized>(
        &self,
        field: &F,
        y_n: &[T],
        lambda: &[T],
        d_params: &[T],
    ) {
        self.check(field, y_n);
        assert_eq!(
            lambda.len(),
            self.n,
            "cotangent length differs from the layout"
        );
        assert_eq!(
            d_params.len(),
            field.n_params(),
            "parameter-gradient length differs from the field"
        );
    }

    /// [`step_vjp`](Self::step_vjp) of a step taken by
    /// [`step_recorded`](Self::step_recorded): with `Some(kept)` (what it kept) the stage
    /// values are read from its outputs, the slopes, states and increments are taken from
    /// its stages (and handed back after) and each stage's VJP reads its record, so no stage
    /// is formed again; with `None` the stages are evaluated again into `scratch` (one record
    /// per stage) and their VJPs read those. Bitwise the same as `step_vjp`.
    pub(crate) fn step_vjp_recorded<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y_n: &[T],
        kept: Option<KeptStep<'_, T, F::Record>>,
        scratch: &mut [F::Record],
        lambda: &mut [T],
        d_params: &mut [T],
    ) {
        self.check_vjp(field, y_n, lambda, d_params);
        let upto = self.needed_stages();
        self.ensure_adjoint_buffers();
        let combo = Combo::new((0..self.s).map(|i| (i, self.b[i])));
        match kept {
            Some(KeptStep {
                outputs,
                records,
                stages,
            }) => {
                self.exchange_stages(stages);
                self.update_pass(&combo, h, lambda, true);
                self.vjp_stages_with(
                    field,
                    t,
                    h,
                    y_n,
                    upto,
                    outputs,
                    lambda,
                    d_params,
                    Some(records),
                );
                // The tape keeps the step's stages, so a second reverse pass reads them too.
                self.exchange_stages(stages);
            }
            None => {
                let mut values = StageValues::Record {
                    outputs: None,
                    records: &mut *scratch,
                };
                self.recompute_stages(field, t, h, y_n, upto, &mut values);
                self.update_pass(&combo, h, lambda, true);
                let f = core::mem::take(&mut self.adj.f);
                self.vjp_stages_with(field, t, h, y_n, upto, &f, lambda, d_params, Some(scratch));
                self.adj.f = f;
            }
        }
    }

    /// Starts the reverse pass of a step from `(t, y_n)`: recomputes stages `0..upto`
    /// and clears the stage cotangents `K̄ᵢ`. Then [`vjp_update`](Self::vjp_update) once
    /// per update term that read the stages, then [`vjp_stages`](Self::vjp_stages).
    pub(crate) fn vjp_begin<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y_n: &[T],
        upto: usize,
    ) {
        self.ensure_adjoint_buffers();
        self.recompute_stages(field, t, h, y_n, upto, &mut StageValues::Eval);
        self.adj.kb.fill(T::ZERO);
    }

    /// Transposes one update term `y_n ⊕ h Σ wᵢKᵢ` (the step's own with `w = b`, or a
    /// continuous extension's): `lambda` (on entry the cotangent at the term's value) is
    /// replaced by its pull-back through `y_n ⊕ ·` alone, and `K̄ᵢ += h wᵢ Ω̄`. Returns
    /// `⟨Ω̄, h Σ dwᵢKᵢ⟩`, the derivative of the loss along a change `dw` of the weights (0
    /// without `dw`).
    pub(crate) fn vjp_update(&mut self, w: &[T], dw: Option<&[T]>, h: T, lambda: &mut [T]) -> T {
        let combo = Combo::new(w.iter().copied().enumerate());
        self.update_pass(&combo, h, lambda, false);
        let Some(dw) = dw else {
            return T::ZERO;
        };
        let (n, pt, r) = (self.n, self.pat.pt, self.kb_len());
        let ob = self.s * pt;
        let mut acc = T::ZERO;
        for (i, &d) in dw.iter().enumerate() {
            if d == T::ZERO {
                continue;
            }
            // Ω̄ against Kᵢ, entry by entry in tangent order.
            let mut part = T::ZERO;
            let ki = &self.k[i * n..(i + 1) * n];
            // (A layout of no entries has nothing to add, and no chunks of zero length.)
            if pt > 0 {
                for (kb, kp) in self.adj.kb.chunks_exact(r).zip(ki.chunks_exact(pt)) {
                    for (o, k) in kb[ob..ob + pt].iter().zip(kp) {
                        part += *o * *k;
                    }
                }
            }
            acc += h * d * part;
        }
        acc
    }

    /// The stage loop of the reverse pass (stages `upto − 1, …, 0`): adds the cotangent at
    /// `y_n` carried by the stages into `lambda` and the parameter gradient into
    /// `d_params`.
    pub(crate) fn vjp_stages<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y_n: &[T],
        upto: usize,
        lambda: &mut [T],
        d_params: &mut [T],
    ) {
        let f = core::mem::take(&mut self.adj.f);
        self.vjp_stages_with(field, t, h, y_n, upto, &f, lambda, d_params, None);
        self.adj.f = f;
    }

    /// [`vjp_stages`](Self::vjp_stages) with the stages' field values `Fᵢ` in `f` (stage
    /// `i` at `f[i·n..]`), each stage's field VJP reading `records[i]` when given (written
    /// by the field at that stage). Between two field VJPs one pass over the particles does
    /// all the per-particle work: the transpose of stage `i`'s state and its coupling into
    /// the earlier stages' `K̄ⱼ`, then the cotangent handed to stage `i − 1`'s field VJP
    /// ([`Stepper::stage_pass`]).
    #[allow(
        clippy::too_many_arguments,
        reason = "the field, the step, the stage values and records, and the two gradients"
    )]
    fn vjp_stages_with<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y_n: &[T],
        upto: usize,
        f: &[T],
        lambda: &mut [T],
        d_params: &mut [T],
        records: Option<&[F::Record]>,
    ) {
        let na = y_n.len();
        let field_vjp =
            |field: &mut F, i: usize, ti: T, x: &[T], w: &[T], xbar: &mut [T], dp: &mut [T]| {
                match records {
                    Some(r) => field.vjp_recorded(ti, x, &r[i], w, xbar, dp),
                    None => field.vjp(ti, x, w, xbar, dp),
                }
            };
        self.stage_pass(None, Some(upto - 1), h, f, lambda);
        for i in (0..upto).rev() {
            let ti = t + self.c[i] * h;
            let x = if i == 0 {
                y_n
            } else {
                &self.x[i * na..(i + 1) * na]
            };
            field_vjp(field, i, ti, x, &self.adj.w, &mut self.adj.xbar, d_params);
            if i == 0 {
                // Ω₀ = 0: X₀ = yₙ, so the stage's state transposes to the identity.
                for (l, xb) in lambda.iter_mut().zip(&self.adj.xbar) {
                    *l += *xb;
                }
            } else {
                self.stage_pass(Some(i), Some(i - 1), h, f, lambda);
            }
        }
    }

    fn ensure_adjoint_buffers(&mut self) {
        let (s, n) = (self.s, self.n);
        if self.adj.f.len() != s * n {
            self.adj.f = vec![T::ZERO; s * n];
            self.adj.kb = vec![T::ZERO; self.count * self.kb_len()];
            self.adj.w = vec![T::ZERO; n];
            self.adj.xbar = vec![T::ZERO; n];
        }
    }

    /// Entries per particle of the stage-cotangent buffer: `K̄₀ … K̄ₛ₋₁` then `Ω̄`, one
    /// tangent each.
    const fn kb_len(&self) -> usize {
        (self.s + 1) * self.pat.pt
    }

    /// The forward stages `0..upto` again, keeping the field outputs `Fᵢ` next to `Kᵢ`
    /// (the field values from `values`).
    fn recompute_stages<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y: &[T],
        upto: usize,
        values: &mut StageValues<'_, T, F::Record>,
    ) {
        let (n, na) = (self.n, y.len());
        for i in 0..upto {
            let ti = t + self.c[i] * h;
            if i == 0 {
                values.value(field, 0, ti, y, &mut self.adj.f[..n]);
            } else {
                self.stage_point(i, h, y);
                let xi = &self.x[i * na..(i + 1) * na];
                values.value(field, i, ti, xi, &mut self.adj.f[i * n..(i + 1) * n]);
            }
            self.k[i * n..(i + 1) * n].copy_from_slice(&self.adj.f[i * n..(i + 1) * n]);
            if i > 0 {
                self.dexp_inv(i);
            }
        }
    }

    /// Transposes the update `y ⊕ Ω` with `Ω = h Σ wᵢKᵢ`, particle by particle:
    /// `λ ← Exp(Ω)ᵀλ` (SO(3)) or `λ ← Ad(Exp(Ω))ᵀλ` (SE(3)) and `Ω̄ = Jl(Ω)ᵀλ` on Lie-group
    /// blocks, `Ω̄ = λ` on Euclidean ones; then `K̄ᵢ += h wᵢ Ω̄` for every term (after
    /// clearing every `K̄ᵢ` first with `clear`).
    fn update_pass(&mut self, combo: &Combo<T>, h: T, lambda: &mut [T], clear: bool) {
        let (pat, n, r) = (self.pat, self.n, self.kb_len());
        let (pt, ob) = (pat.pt, self.s * pat.pt);
        let k = &self.k;
        for_chunks2(
            self.par,
            self.count,
            lambda,
            pt,
            &mut self.adj.kb,
            r,
            |p0, np, lc, kc| {
                for p in 0..np {
                    let gt = (p0 + p) * pt;
                    let lp = &mut lc[p * pt..(p + 1) * pt];
                    let kp = &mut kc[p * r..(p + 1) * r];
                    if clear {
                        kp.fill(T::ZERO);
                    }
                    let (kbars, obar) = kp.split_at_mut(ob);
                    for sp in pat.spans() {
                        let e = sp.tangent;
                        match sp.block {
                            Block::Euclidean(m) => {
                                obar[e..e + m].copy_from_slice(&lp[e..e + m]);
                            }
                            Block::So3 => {
                                let big = combo.vec3(k, n, gt + e) * h;
                                let l = Vec3::from_slice(&lp[e..]);
                                jl_tr_mul(big, l).write_to(&mut obar[e..]);
                                exp_quat(big).rotate_inv(l).write_to(&mut lp[e..]);
                            }
                            Block::Se3 => {
                                let big = combo.vec6(k, n, gt + e) * h;
                                let l = Vec6::from_slice(&lp[e..]);
                                se3_jacobians::jl_tr_mul(big, l).write_to(&mut obar[e..]);
                                Se3::exp(big).adjoint_tr_mul(l).write_to(&mut lp[e..]);
                            }
                        }
                    }
                    for &(i, wi) in combo.terms() {
                        let hw = h * wi;
                        for (kb, o) in kbars[i * pt..(i + 1) * pt].iter_mut().zip(&*obar) {
                            *kb += hw * *o;
                        }
                    }
                }
            },
        );
    }

    /// One pass over the particles between two field VJPs of the reverse stage loop:
    ///
    /// - with `post = Some(i)`, the transpose of stage `i`'s state `Xᵢ = yₙ ⊕ Ωᵢ` at the
    ///   field VJP's `X̄ᵢ` (`λ += X̄ᵢ`, `Ω̄ᵢ = X̄ᵢ` on Euclidean blocks; `λ += Exp(Ωᵢ)ᵀX̄ᵢ`,
    ///   `Ω̄ᵢ += Jl(Ωᵢ)ᵀX̄ᵢ` on SO(3); the adjoint action and the SE(3) Jacobian on SE(3)),
    ///   then its coupling `K̄ⱼ += h a_ij Ω̄ᵢ` into the earlier stages (`j < i`);
    /// - with `pre = Some(j)`, the cotangent of stage `j`'s field output for its VJP, into
    ///   `w`: `K̄ⱼ` on Euclidean blocks and on every block of stage 0 (`Ω₀ = 0`), and on
    ///   SO(3) and SE(3) blocks `ω̄ⱼ` with `Ω̄ⱼ` (into `Ω̄`) from the VJP of `Jl⁻¹(Ωⱼ)·ωⱼ`
    ///   at `K̄ⱼ` (`ωⱼ = Fⱼ`, from `f`); and `X̄` cleared for the VJP to add into.
    ///
    /// Each particle's entries see the operations of the separate passes in their order,
    /// so the result is theirs bit for bit, in one trip over the particles.
    fn stage_pass(
        &mut self,
        post: Option<usize>,
        pre: Option<usize>,
        h: T,
        f: &[T],
        lambda: &mut [T],
    ) {
        let (pat, n, r, s) = (self.pat, self.n, self.kb_len(), self.s);
        let (pt, ob) = (pat.pt, s * pat.pt);
        let (a, omega) = (&self.a, &self.omega);
        for_chunks4(
            self.par,
            self.count,
            [
                lambda,
                &mut self.adj.kb,
                &mut self.adj.w,
                &mut self.adj.xbar,
            ],
            [pt, r, pt, pt],
            |p0, np, [lc, kc, wc, xc]| {
                for p in 0..np {
                    let gt = (p0 + p) * pt;
                    let lp = &mut lc[p * pt..(p + 1) * pt];
                    let (kbars, obar) = kc[p * r..(p + 1) * r].split_at_mut(ob);
                    let wp = &mut wc[p * pt..(p + 1) * pt];
                    let xp = &mut xc[p * pt..(p + 1) * pt];
                    if let Some(i) = post {
                        let om = &omega[i * n + gt..i * n + gt + pt];
                        for sp in pat.spans() {
                            let e = sp.tangent;
                            match sp.block {
                                Block::Euclidean(m) => {
                                    for (l, xb) in lp[e..e + m].iter_mut().zip(&xp[e..e + m]) {
                                        *l += *xb;
                                    }
                                    obar[e..e + m].copy_from_slice(&xp[e..e + m]);
                                }
                                Block::So3 => {
                                    let big = Vec3::from_slice(&om[e..]);
                                    let xb = Vec3::from_slice(&xp[e..]);
                                    let l =
                                        Vec3::from_slice(&lp[e..]) + exp_quat(big).rotate_inv(xb);
                                    l.write_to(&mut lp[e..]);
                                    let o = Vec3::from_slice(&obar[e..]) + jl_tr_mul(big, xb);
                                    o.write_to(&mut obar[e..]);
                                }
                                Block::Se3 => {
                                    let big = Vec6::from_slice(&om[e..]);
                                    let xb = Vec6::from_slice(&xp[e..]);
                                    Se3::exp(big).adjoint_tr_mul(xb).add_to(&mut lp[e..]);
                                    se3_jacobians::jl_tr_mul(big, xb).add_to(&mut obar[e..]);
                                }
                            }
                        }
                        for j in 0..i {
                            let aij = a[i][j];
                            if aij == T::ZERO {
                                continue;
                            }
                            let ha = h * aij;
                            for (kb, o) in kbars[j * pt..(j + 1) * pt].iter_mut().zip(&*obar) {
                                *kb += ha * *o;
                            }
                        }
                    }
                    if let Some(j) = pre {
                        xp.fill(T::ZERO);
                        let kbar = &kbars[j * pt..(j + 1) * pt];
                        if j == 0 {
                            wp.copy_from_slice(kbar);
                            continue;
                        }
                        let (om, fj) = (&omega[j * n + gt..], &f[j * n + gt..]);
                        for sp in pat.spans() {
                            let e = sp.tangent;
                            match sp.block {
                                Block::Euclidean(m) => {
                                    wp[e..e + m].copy_from_slice(&kbar[e..e + m]);
                                }
                                Block::So3 => {
                                    let (d_big, d_omega) = jl_inv_mul_vjp(
                                        Vec3::from_slice(&om[e..]),
                                        Vec3::from_slice(&fj[e..]),
                                        Vec3::from_slice(&kbar[e..]),
                                    );
                                    d_omega.write_to(&mut wp[e..]);
                                    d_big.write_to(&mut obar[e..]);
                                }
                                Block::Se3 => {
                                    let (d_big, d_xi) = se3_jacobians::jl_inv_mul_vjp(
                                        Vec6::from_slice(&om[e..]),
                                        Vec6::from_slice(&fj[e..]),
                                        Vec6::from_slice(&kbar[e..]),
                                    );
                                    d_xi.write_to(&mut wp[e..]);
                                    d_big.write_to(&mut obar[e..]);
                                }
                            }
                        }
                    }
                }
            },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::Stepper;
    use crate::fields::LinearField;
    use crate::{Method, StateLayout};

    fn stepper_and_field() -> (Stepper<f64>, LinearField<f64>) {
        let f = LinearField::new(2, alloc::vec![0.1, -0.4, 0.3, 0.2]);
        (Stepper::new(Method::Rk4, StateLayout::euclidean(2)), f)
    }

    #[test]
    #[should_panic(expected = "cotangent length differs from the layout")]
    fn a_cotangent_of_another_length_is_refused() {
        let (mut st, mut f) = stepper_and_field();
        st.step_vjp(&mut f, 0.0, 0.1, &[1.0, 2.0], &mut [1.0; 3], &mut [0.0; 4]);
    }

    #[test]
    #[should_panic(expected = "parameter-gradient length differs from the field")]
    fn a_parameter_gradient_of_another_length_is_refused() {
        let (mut st, mut f) = stepper_and_field();
        st.step_vjp(&mut f, 0.0, 0.1, &[1.0, 2.0], &mut [1.0; 2], &mut [0.0; 3]);
    }

    #[test]
    #[should_panic(expected = "state length differs from the layout")]
    fn a_state_of_another_length_is_refused_by_the_vjp() {
        let (mut st, mut f) = stepper_and_field();
        st.step_vjp(&mut f, 0.0, 0.1, &[1.0], &mut [1.0; 2], &mut [0.0; 4]);
    }

    /// "Later calls allocate nothing": the reverse-pass buffers of the first VJP are the
    /// ones every later VJP writes into (a reallocation would move them: the new buffer is
    /// made while the old one is still alive).
    #[test]
    fn later_vjps_reuse_the_first_ones_buffers() {
        let (mut st, mut f) = stepper_and_field();
        let mut d = [0.0; 4];
        st.step_vjp(&mut f, 0.0, 0.1, &[1.0, 2.0], &mut [1.0, 0.5], &mut d);
        let buffers =
            |st: &Stepper<f64>| (st.adj.f.as_ptr(), st.adj.kb.as_ptr(), st.adj.w.as_ptr());
        let first = buffers(&st);
        for k in 1..4 {
            st.step_vjp(
                &mut f,
                0.1 * f64::from(k),
                0.1,
                &[1.0, 2.0],
                &mut [1.0, 0.5],
                &mut d,
            );
            let now = buffers(&st);
            assert_eq!(now, first, "VJP {k} reallocated the reverse-pass buffers");
        }
    }
}
