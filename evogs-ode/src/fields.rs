//! Example parameterised fields: [`LinearField`] `f = A x` and the two-hidden-layer tanh
//! [`Mlp`] of the ODE reference files (`tests/data/oracle/ode_shared_*.json`).
//!
//! Both are Euclidean, single-state fields with exact VJPs in their parameters; they are
//! what `evogs verify` needs to recompute the reference vectors, and small enough to
//! teach with.

use crate::VectorField;
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::Real;

/// `f(t, x) = A x` on `Rⁿ`, θ = A (row-major, `n²` entries).
///
/// ```
/// use evogs_ode::{VectorField, fields::LinearField};
/// let mut f = LinearField::new(2, vec![0.0, 1.0, -1.0, 0.0]);
/// let mut d = [0.0; 2];
/// f.eval(0.0, &[1.0, 2.0], &mut d);
/// assert_eq!(d, [2.0, -1.0]);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct LinearField<T> {
    n: usize,
    a: Vec<T>,
}

impl<T: Real> LinearField<T> {
    /// `f = A x` with `A` row-major `n × n`.
    ///
    /// # Panics
    /// If `a.len() != n²`.
    #[must_use]
    pub fn new(n: usize, a: Vec<T>) -> Self {
        assert_eq!(a.len(), n * n, "A must have n² entries");
        Self { n, a }
    }

    /// The matrix A (row-major).
    #[must_use]
    pub fn matrix(&self) -> &[T] {
        &self.a
    }

    /// Mutable access to A (the parameters).
    pub fn matrix_mut(&mut self) -> &mut [T] {
        &mut self.a
    }
}

impl<T: Real> VectorField<T> for LinearField<T> {
    type Record = ();
    fn dim(&self) -> usize {
        self.n
    }
    fn n_params(&self) -> usize {
        self.n * self.n
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        for (row, out) in self.a.chunks_exact(self.n).zip(dydt.iter_mut()) {
            *out = row.iter().zip(y).fold(T::ZERO, |acc, (a, x)| acc + *a * *x);
        }
    }
    /// `d_y += Aᵀw`, `dA_ij += w_i y_j`.
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        for (i, (row, d_row)) in self
            .a
            .chunks_exact(self.n)
            .zip(d_params.chunks_exact_mut(self.n))
            .enumerate()
        {
            for j in 0..self.n {
                d_y[j] += row[j] * w[i];
                d_row[j] += w[i] * y[j];
            }
        }
    }
}

/// The reference files' MLP field on `Rⁿ`, with the time as an extra input:
///
/// ```text
/// f(t, x) = W3 tanh(W2 tanh(W1 [x, t] + b1) + b2) + b3
/// W1 [h][n+1], b1 [h], W2 [h][h], b2 [h], W3 [n][h], b3 [n]   (matrices [out][in])
/// θ = W1, b1, W2, b2, W3, b3, each flattened row-major, in that order
/// ```
///
/// The reference uses `n = 3`, `h = 16`. Scratch buffers are allocated once.
#[derive(Clone, Debug, PartialEq)]
pub struct Mlp<T> {
    n: usize,
    h: usize,
    theta: Vec<T>,
    u: Vec<T>,
    a1: Vec<T>,
    a2: Vec<T>,
    g1: Vec<T>,
    g2: Vec<T>,
}

impl<T: Real> Mlp<T> {
    /// Number of parameters for state dimension `n` and hidden width `h`.
    #[must_use]
    pub const fn param_count(n: usize, h: usize) -> usize {
        h * (n + 1) + h + h * h + h + n * h + n
    }

    /// An MLP with parameters `theta` (layout in the type docs).
    ///
    /// # Panics
    /// If `theta.len() != Mlp::param_count(n, h)`.
    #[must_use]
    pub fn new(n: usize, h: usize, theta: Vec<T>) -> Self {
        assert_eq!(
            theta.len(),
            Self::param_count(n, h),
            "θ must hold W1, b1, W2, b2, W3, b3"
        );
        Self {
            n,
            h,
            theta,
            u: vec![T::ZERO; n + 1],
            a1: vec![T::ZERO; h],
            a2: vec![T::ZERO; h],
            g1: vec![T::ZERO; h],
            g2: vec![T::ZERO; h],
        }
    }

    /// The parameters θ.
    #[must_use]
    pub fn params(&self) -> &[T] {
        &self.theta
    }

    /// Mutable access to θ.
    pub fn params_mut(&mut self) -> &mut [T] {
        &mut self.theta
    }

    /// Offsets of W1, b1, W2, b2, W3, b3 in θ.
    const fn offsets(&self) -> [usize; 6] {
        let (n, h) = (self.n, self.h);
        let w1 = 0;
        let b1 = w1 + h * (n + 1);
        let w2 = b1 + h;
        let b2 = w2 + h * h;
        let w3 = b2 + h;
        let b3 = w3 + n * h;
        [w1, b1, w2, b2, w3, b3]
    }

    /// Forward pass into the hidden buffers (`u = [x, t]`, `a1`, `a2`).
    fn hidden(&mut self, t: T, y: &[T]) {
        let (n, h) = (self.n, self.h);
        let [w1, b1, w2, b2, ..] = self.offsets();
        self.u[..n].copy_from_slice(y);
        self.u[n] = t;
        let th = &self.theta;
        for i in 0..h {
            let row = &th[w1 + i * (n + 1)..w1 + (i + 1) * (n + 1)];
            let z = row
                .iter()
                .zip(&self.u)
                .fold(th[b1 + i], |acc, (w, u)| acc + *w * *u);
            self.a1[i] = z.tanh();
        }
        for i in 0..h {
            let row = &th[w2 + i * h..w2 + (i + 1) * h];
            let z = row
                .iter()
                .zip(&self.a1)
                .fold(th[b2 + i], |acc, (w, a)| acc + *w * *a);
            self.a2[i] = z.tanh();
        }
    }
}

impl<T: Real> VectorField<T> for Mlp<T> {
    type Record = ();
    fn dim(&self) -> usize {
        self.n
    }
    fn n_params(&self) -> usize {
        self.theta.len()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        self.hidden(t, y);
        let h = self.h;
        let [.., w3, b3] = self.offsets();
        for (k, out) in dydt.iter_mut().enumerate() {
            let row = &self.theta[w3 + k * h..w3 + (k + 1) * h];
            *out = row
                .iter()
                .zip(&self.a2)
                .fold(self.theta[b3 + k], |acc, (w, a)| acc + *w * *a);
        }
    }
    /// Backpropagation through the three layers (`tanh' = 1 − tanh²`); the time input's
    /// gradient is discarded.
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        self.hidden(t, y);
        let (n, h) = (self.n, self.h);
        let [w1, b1, w2, b2, w3, b3] = self.offsets();
        // Output layer.
        self.g2.fill(T::ZERO);
        for k in 0..n {
            d_params[b3 + k] += w[k];
            for j in 0..h {
                d_params[w3 + k * h + j] += w[k] * self.a2[j];
                self.g2[j] += self.theta[w3 + k * h + j] * w[k];
            }
        }
        for j in 0..h {
            self.g2[j] *= T::ONE - self.a2[j].sq();
        }
        // Second hidden layer.
        self.g1.fill(T::ZERO);
        for i in 0..h {
            d_params[b2 + i] += self.g2[i];
            for j in 0..h {
                d_params[w2 + i * h + j] += self.g2[i] * self.a1[j];
                self.g1[j] += self.theta[w2 + i * h + j] * self.g2[i];
            }
        }
        for j in 0..h {
            self.g1[j] *= T::ONE - self.a1[j].sq();
        }
        // First hidden layer.
        for i in 0..h {
            d_params[b1 + i] += self.g1[i];
            for j in 0..=n {
                d_params[w1 + i * (n + 1) + j] += self.g1[i] * self.u[j];
                if j < n {
                    d_y[j] += self.theta[w1 + i * (n + 1) + j] * self.g1[i];
                }
            }
        }
    }
}
