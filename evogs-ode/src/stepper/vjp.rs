//! The exact VJP of one step: [`Stepper::step_vjp`] (formulas in its docs).

use super::{Combo, KeptStep, StageValues, Stepper, jl_tr_mul};
use crate::chunks::for_chunks2;
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
        self.vjp_begin(field, t, h, y_n, upto);
        let combo = Combo::new((0..self.s).map(|i| (i, self.b[i])));
        self.update_vjp(&combo, h, lambda);
        self.add_kbar(&combo, h);
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
    /// values are copied from `outputs`, the slopes, states and
    /// increments are taken from `stages` (and handed back after) and each stage's VJP reads
    /// its record, so no stage is formed again; with `None` the stages are evaluated again
    /// into `scratch` (one record per stage) and their VJPs read those. Bitwise the same as
    /// `step_vjp`.
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
        let (records, stages): (&[F::Record], _) = match kept {
            Some(KeptStep {
                outputs,
                records,
                stages,
            }) => {
                let m = upto * self.n;
                self.adj.f[..m].copy_from_slice(&outputs[..m]);
                self.exchange_stages(stages);
                (records, Some(stages))
            }
            None => {
                let mut values = StageValues::Record {
                    outputs: None,
                    records: &mut *scratch,
                };
                self.recompute_stages(field, t, h, y_n, upto, &mut values);
                (&*scratch, None)
            }
        };
        self.adj.kbar.fill(T::ZERO);
        let combo = Combo::new((0..self.s).map(|i| (i, self.b[i])));
        self.update_vjp(&combo, h, lambda);
        self.add_kbar(&combo, h);
        self.vjp_stages_with(field, t, h, y_n, upto, lambda, d_params, Some(records));
        if let Some(stages) = stages {
            // The tape keeps the step's stages, so a second reverse pass reads them too.
            self.exchange_stages(stages);
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
        self.adj.kbar.fill(T::ZERO);
    }

    /// Transposes one update term `y_n ⊕ h Σ wᵢKᵢ` (the step's own with `w = b`, or a
    /// continuous extension's): `lambda` (on entry the cotangent at the term's value) is
    /// replaced by its pull-back through `y_n ⊕ ·` alone, and `K̄ᵢ += h wᵢ Ω̄`. Returns
    /// `⟨Ω̄, h Σ dwᵢKᵢ⟩`, the derivative of the loss along a change `dw` of the weights (0
    /// without `dw`).
    pub(crate) fn vjp_update(&mut self, w: &[T], dw: Option<&[T]>, h: T, lambda: &mut [T]) -> T {
        let combo = Combo::new(w.iter().copied().enumerate());
        self.update_vjp(&combo, h, lambda);
        self.add_kbar(&combo, h);
        let Some(dw) = dw else {
            return T::ZERO;
        };
        let n = self.n;
        let mut acc = T::ZERO;
        for (i, &d) in dw.iter().enumerate() {
            if d == T::ZERO {
                continue;
            }
            let mut part = T::ZERO;
            for (o, k) in self.adj.obar.iter().zip(&self.k[i * n..(i + 1) * n]) {
                part += *o * *k;
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
        self.vjp_stages_with(field, t, h, y_n, upto, lambda, d_params, None);
    }

    /// [`vjp_stages`](Self::vjp_stages), each stage's field VJP reading `records[i]` when
    /// given (written by the field at that stage).
    fn vjp_stages_with<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        t: T,
        h: T,
        y_n: &[T],
        upto: usize,
        lambda: &mut [T],
        d_params: &mut [T],
        records: Option<&[F::Record]>,
    ) {
        let (n, na) = (self.n, y_n.len());
        let field_vjp =
            |field: &mut F, i: usize, ti: T, x: &[T], w: &[T], xbar: &mut [T], dp: &mut [T]| {
                match records {
                    Some(r) => field.vjp_recorded(ti, x, &r[i], w, xbar, dp),
                    None => field.vjp(ti, x, w, xbar, dp),
                }
            };
        for i in (0..upto).rev() {
            let ti = t + self.c[i] * h;
            self.adj.xbar.fill(T::ZERO);
            if i == 0 {
                // Ω₀ = 0: K₀ = ω₀ and X₀ = yₙ, so every Jacobian of the stage is the identity.
                let kbar0 = &self.adj.kbar[..n];
                field_vjp(field, 0, ti, y_n, kbar0, &mut self.adj.xbar, d_params);
                for (l, xb) in lambda.iter_mut().zip(&self.adj.xbar) {
                    *l += *xb;
                }
                continue;
            }
            // Xᵢ and Ωᵢ are in stage i's slots since the stages were recomputed.
            if self.euclidean {
                let xi = &self.x[i * na..(i + 1) * na];
                let kbar_i = &self.adj.kbar[i * n..(i + 1) * n];
                field_vjp(field, i, ti, xi, kbar_i, &mut self.adj.xbar, d_params);
                for (l, xb) in lambda.iter_mut().zip(&self.adj.xbar) {
                    *l += *xb;
                }
                self.couple(i, h, true);
            } else {
                self.stage_field_cotangent(i);
                let xi = &self.x[i * na..(i + 1) * na];
                field_vjp(field, i, ti, xi, &self.adj.w, &mut self.adj.xbar, d_params);
                self.stage_state_vjp(i, lambda);
                self.couple(i, h, false);
            }
        }
    }

    fn ensure_adjoint_buffers(&mut self) {
        let (s, n) = (self.s, self.n);
        if self.adj.kbar.len() != s * n {
            self.adj.f = vec![T::ZERO; s * n];
            self.adj.kbar = vec![T::ZERO; s * n];
            self.adj.w = vec![T::ZERO; n];
            self.adj.xbar = vec![T::ZERO; n];
            self.adj.obar = vec![T::ZERO; n];
        }
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

    /// Transposes the update `y ⊕ Ω` with `Ω = h Σ wᵢKᵢ`: `λ ← Exp(Ω)ᵀλ` (SO(3)) or
    /// `λ ← Ad(Exp(Ω))ᵀλ` (SE(3)) and `Ω̄ = Jl(Ω)ᵀλ` on Lie-group blocks, `Ω̄ = λ` on
    /// Euclidean ones.
    fn update_vjp(&mut self, combo: &Combo<T>, h: T, lambda: &mut [T]) {
        let (pat, n, k) = (self.pat, self.n, &self.k);
        for_chunks2(
            self.par,
            self.count,
            lambda,
            pat.pt,
            &mut self.adj.obar,
            pat.pt,
            |p0, np, lc, oc| {
                for p in 0..np {
                    let gt = (p0 + p) * pat.pt;
                    let lt = p * pat.pt;
                    for sp in pat.spans() {
                        let e = lt + sp.tangent;
                        match sp.block {
                            Block::Euclidean(m) => {
                                oc[e..e + m].copy_from_slice(&lc[e..e + m]);
                            }
                            Block::So3 => {
                                let big = combo.vec3(k, n, gt + sp.tangent) * h;
                                let l = Vec3::from_slice(&lc[e..]);
                                jl_tr_mul(big, l).write_to(&mut oc[e..]);
                                exp_quat(big).rotate_inv(l).write_to(&mut lc[e..]);
                            }
                            Block::Se3 => {
                                let big = combo.vec6(k, n, gt + sp.tangent) * h;
                                let l = Vec6::from_slice(&lc[e..]);
                                se3_jacobians::jl_tr_mul(big, l).write_to(&mut oc[e..]);
                                Se3::exp(big).adjoint_tr_mul(l).write_to(&mut lc[e..]);
                            }
                        }
                    }
                }
            },
        );
    }

    /// `K̄ᵢ += h wᵢ Ω̄` for the weights of an update term.
    fn add_kbar(&mut self, combo: &Combo<T>, h: T) {
        let n = self.n;
        for &(i, w) in combo.terms() {
            let hw = h * w;
            for (kb, ob) in self.adj.kbar[i * n..(i + 1) * n]
                .iter_mut()
                .zip(&self.adj.obar)
            {
                *kb += hw * *ob;
            }
        }
    }

    /// The cotangent of the field output at stage `i`: `K̄ᵢ` on Euclidean entries, and on
    /// SO(3) and SE(3) entries `ω̄ᵢ` with `Ω̄ᵢ` (into `obar`) from the VJP of `Jl⁻¹(Ωᵢ)·ωᵢ`.
    fn stage_field_cotangent(&mut self, i: usize) {
        let (pat, n) = (self.pat, self.n);
        let (omega, f, kbar) = (&self.omega[i * n..(i + 1) * n], &self.adj.f, &self.adj.kbar);
        for_chunks2(
            self.par,
            self.count,
            &mut self.adj.w,
            pat.pt,
            &mut self.adj.obar,
            pat.pt,
            |p0, np, wc, oc| {
                for p in 0..np {
                    let gt = (p0 + p) * pat.pt;
                    let lt = p * pat.pt;
                    for sp in pat.spans() {
                        let (e, ge) = (lt + sp.tangent, gt + sp.tangent);
                        match sp.block {
                            Block::Euclidean(m) => {
                                wc[e..e + m].copy_from_slice(&kbar[i * n + ge..i * n + ge + m]);
                            }
                            Block::So3 => {
                                let (d_big, d_omega) = jl_inv_mul_vjp(
                                    Vec3::from_slice(&omega[ge..]),
                                    Vec3::from_slice(&f[i * n + ge..]),
                                    Vec3::from_slice(&kbar[i * n + ge..]),
                                );
                                d_omega.write_to(&mut wc[e..]);
                                d_big.write_to(&mut oc[e..]);
                            }
                            Block::Se3 => {
                                let (d_big, d_xi) = se3_jacobians::jl_inv_mul_vjp(
                                    Vec6::from_slice(&omega[ge..]),
                                    Vec6::from_slice(&f[i * n + ge..]),
                                    Vec6::from_slice(&kbar[i * n + ge..]),
                                );
                                d_xi.write_to(&mut wc[e..]);
                                d_big.write_to(&mut oc[e..]);
                            }
                        }
                    }
                }
            },
        );
    }

    /// Transposes `Xᵢ = yₙ ⊕ Ωᵢ`: `λ += X̄ᵢ`, `Ω̄ᵢ = X̄ᵢ` (Euclidean);
    /// `λ += Exp(Ωᵢ)ᵀX̄ᵢ`, `Ω̄ᵢ += Jl(Ωᵢ)ᵀX̄ᵢ` (SO(3));
    /// `λ += Ad(Exp(Ωᵢ))ᵀX̄ᵢ`, `Ω̄ᵢ += Jl(Ωᵢ)ᵀX̄ᵢ` (SE(3)).
    fn stage_state_vjp(&mut self, i: usize, lambda: &mut [T]) {
        let (pat, n) = (self.pat, self.n);
        let (omega, xbar) = (&self.omega[i * n..(i + 1) * n], &self.adj.xbar);
        for_chunks2(
            self.par,
            self.count,
            lambda,
            pat.pt,
            &mut self.adj.obar,
            pat.pt,
            |p0, np, lc, oc| {
                for p in 0..np {
                    let gt = (p0 + p) * pat.pt;
                    let lt = p * pat.pt;
                    for sp in pat.spans() {
                        let (e, ge) = (lt + sp.tangent, gt + sp.tangent);
                        match sp.block {
                            Block::Euclidean(m) => {
                                for (l, xb) in lc[e..e + m].iter_mut().zip(&xbar[ge..ge + m]) {
                                    *l += *xb;
                                }
                                oc[e..e + m].copy_from_slice(&xbar[ge..ge + m]);
                            }
                            Block::So3 => {
                                let big = Vec3::from_slice(&omega[ge..]);
                                let xb = Vec3::from_slice(&xbar[ge..]);
                                let l = Vec3::from_slice(&lc[e..]) + exp_quat(big).rotate_inv(xb);
                                l.write_to(&mut lc[e..]);
                                let o = Vec3::from_slice(&oc[e..]) + jl_tr_mul(big, xb);
                                o.write_to(&mut oc[e..]);
                            }
                            Block::Se3 => {
                                let big = Vec6::from_slice(&omega[ge..]);
                                let xb = Vec6::from_slice(&xbar[ge..]);
                                Se3::exp(big).adjoint_tr_mul(xb).add_to(&mut lc[e..]);
                                se3_jacobians::jl_tr_mul(big, xb).add_to(&mut oc[e..]);
                            }
                        }
                    }
                }
            },
        );
    }

    /// `K̄ⱼ += h a_ij Ω̄ᵢ` for `j < i` (`Ω̄ᵢ = X̄ᵢ` when the layout is Euclidean).
    fn couple(&mut self, i: usize, h: T, euclidean: bool) {
        let n = self.n;
        let src = if euclidean {
            &self.adj.xbar
        } else {
            &self.adj.obar
        };
        for j in 0..i {
            let a = self.a[i][j];
            if a == T::ZERO {
                continue;
            }
            let ha = h * a;
            for (kb, o) in self.adj.kbar[j * n..(j + 1) * n].iter_mut().zip(src) {
                *kb += ha * *o;
            }
        }
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
        let buffers = |st: &Stepper<f64>| {
            (
                st.adj.f.as_ptr(),
                st.adj.kbar.as_ptr(),
                st.adj.obar.as_ptr(),
            )
        };
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
