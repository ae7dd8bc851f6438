//! Classic non-stiff test problems without closed forms, for adaptive solvers and their
//! gradients (the problems of the adaptive reference file, `ode_adaptive_shared.json`,
//! implemented from their parameters): [`VanDerPol`], [`Kepler`], [`Lorenz`],
//! [`EulerRates`], [`ForcedOscillator`], and [`by_name`] to build one from its name.
//!
//! Each is a [`VectorField`] whose parameters θ are the problem's constants, with an exact
//! VJP (also with respect to θ).

use crate::VectorField;
use alloc::boxed::Box;
use alloc::vec::Vec;
use evogs_math::Real;

/// Van der Pol's oscillator `x0' = x1`, `x1' = μ(1 − x0²)x1 − x0`; θ = (μ).
///
/// Non-stiff for μ ≈ 1, increasingly stiff for large μ (an explicit pair then takes many
/// rejected steps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VanDerPol<T> {
    /// μ.
    pub mu: T,
}

impl<T: Real> VectorField<T> for VanDerPol<T> {
    type Record = ();
    fn dim(&self) -> usize {
        2
    }
    fn n_params(&self) -> usize {
        1
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        dydt[0] = y[1];
        dydt[1] = self.mu * (T::ONE - y[0] * y[0]) * y[1] - y[0];
    }
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let (x0, x1) = (y[0], y[1]);
        d_y[0] += w[1] * (-T::TWO * self.mu * x0 * x1 - T::ONE);
        d_y[1] += w[0] + w[1] * self.mu * (T::ONE - x0 * x0);
        d_params[0] += w[1] * (T::ONE - x0 * x0) * x1;
    }
}

/// The Kepler problem `q' = p`, `p' = −μ q/|q|³` in the plane, state `(qx, qy, px, py)`;
/// θ = (μ) (μ = 1 in the reference file).
///
/// [`Kepler::initial_state`] starts at perihelion with eccentricity e (period 2π for
/// μ = 1): `(1 − e, 0, 0, sqrt((1 + e)/(1 − e)))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kepler<T> {
    /// The gravitational parameter μ.
    pub mu: T,
}

impl<T: Real> Default for Kepler<T> {
    fn default() -> Self {
        Self { mu: T::ONE }
    }
}

impl<T: Real> Kepler<T> {
    /// The perihelion state of the orbit of eccentricity `e` (semi-major axis 1, μ = 1).
    #[must_use]
    pub fn initial_state(e: T) -> [T; 4] {
        [
            T::ONE - e,
            T::ZERO,
            T::ZERO,
            ((T::ONE + e) / (T::ONE - e)).sqrt(),
        ]
    }

    /// The energy `|p|²/2 − μ/|q|` of a state (conserved).
    #[must_use]
    pub fn energy(&self, y: &[T]) -> T {
        T::HALF * (y[2] * y[2] + y[3] * y[3]) - self.mu / (y[0] * y[0] + y[1] * y[1]).sqrt()
    }
}

impl<T: Real> VectorField<T> for Kepler<T> {
    type Record = ();
    fn dim(&self) -> usize {
        4
    }
    fn n_params(&self) -> usize {
        1
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        let r2 = y[0] * y[0] + y[1] * y[1];
        let inv_r3 = T::ONE / (r2 * r2.sqrt());
        dydt[0] = y[2];
        dydt[1] = y[3];
        dydt[2] = -self.mu * y[0] * inv_r3;
        dydt[3] = -self.mu * y[1] * inv_r3;
    }
    /// `∂p'/∂q = −μ(I/r³ − 3qqᵀ/r⁵)` (symmetric).
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let (qx, qy) = (y[0], y[1]);
        let r2 = qx * qx + qy * qy;
        let inv_r3 = T::ONE / (r2 * r2.sqrt());
        let inv_r5 = inv_r3 / r2;
        let qw = qx * w[2] + qy * w[3];
        let three = T::from_f64(3.0);
        d_y[0] += -self.mu * (w[2] * inv_r3 - three * qx * qw * inv_r5);
        d_y[1] += -self.mu * (w[3] * inv_r3 - three * qy * qw * inv_r5);
        d_y[2] += w[0];
        d_y[3] += w[1];
        d_params[0] += -qw * inv_r3;
    }
}

/// The Lorenz system `x' = σ(y − x)`, `y' = x(ρ − z) − y`, `z' = xy − βz`; θ = [σ, ρ, β].
///
/// Chaotic for the classical (10, 28, 8/3): errors grow like `e^{0.9t}`, so reference
/// solutions are only meaningful over a few time units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lorenz<T> {
    /// σ.
    pub sigma: T,
    /// ρ.
    pub rho: T,
    /// β.
    pub beta: T,
}

impl<T: Real> Default for Lorenz<T> {
    fn default() -> Self {
        Self {
            sigma: T::from_f64(10.0),
            rho: T::from_f64(28.0),
            beta: T::from_f64(8.0) / T::from_f64(3.0),
        }
    }
}

impl<T: Real> VectorField<T> for Lorenz<T> {
    type Record = ();
    fn dim(&self) -> usize {
        3
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, _t: T, v: &[T], dydt: &mut [T]) {
        let (x, y, z) = (v[0], v[1], v[2]);
        dydt[0] = self.sigma * (y - x);
        dydt[1] = x * (self.rho - z) - y;
        dydt[2] = x * y - self.beta * z;
    }
    fn vjp(&mut self, _t: T, v: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let (x, y, z) = (v[0], v[1], v[2]);
        d_y[0] += -self.sigma * w[0] + (self.rho - z) * w[1] + y * w[2];
        d_y[1] += self.sigma * w[0] - w[1] + x * w[2];
        d_y[2] += -x * w[1] - self.beta * w[2];
        d_params[0] += (y - x) * w[0];
        d_params[1] += x * w[1];
        d_params[2] += -z * w[2];
    }
}

/// Euler's equations of the torque-free rigid body in the body frame, `I ω' = (Iω) × ω`
/// with `I = diag(I₀, I₁, I₂)`, i.e. `ω'ₖ = (Iᵢ − Iⱼ) ωᵢ ωⱼ / Iₖ` for (k, i, j) cyclic;
/// θ = I.
///
/// The rates alone (no attitude; [`RigidBody`](super::RigidBody) carries the attitude
/// too). Invariants: the energy `½ωᵀIω` and `|Iω|²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EulerRates<T> {
    /// Principal moments of inertia.
    pub inertia: [T; 3],
}

impl<T: Real> EulerRates<T> {
    /// The energy `½ ωᵀIω`.
    #[must_use]
    pub fn energy(&self, w: &[T]) -> T {
        T::HALF * (0..3).map(|k| self.inertia[k] * w[k] * w[k]).sum::<T>()
    }
}

/// `(k, i, j)` cyclic.
const CYCLIC: [(usize, usize, usize); 3] = [(0, 1, 2), (1, 2, 0), (2, 0, 1)];

impl<T: Real> VectorField<T> for EulerRates<T> {
    type Record = ();
    fn dim(&self) -> usize {
        3
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, _t: T, w: &[T], dydt: &mut [T]) {
        let i = &self.inertia;
        for (k, a, b) in CYCLIC {
            dydt[k] = (i[a] - i[b]) * w[a] * w[b] / i[k];
        }
    }
    fn vjp(&mut self, _t: T, w: &[T], v: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let i = self.inertia;
        for (k, a, b) in CYCLIC {
            let g = v[k] / i[k];
            let c = i[a] - i[b];
            let ww = w[a] * w[b];
            d_y[a] += g * c * w[b];
            d_y[b] += g * c * w[a];
            d_params[a] += g * ww;
            d_params[b] -= g * ww;
            d_params[k] -= g * c * ww / i[k];
        }
    }
}

/// A damped oscillator with a periodically modulated stiffness,
/// `x0' = x1`, `x1' = −(1 + a sin(w t)) x0 − c x1` (non-autonomous); θ = [a, w, c].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForcedOscillator<T> {
    /// Modulation depth a.
    pub a: T,
    /// Modulation frequency w.
    pub w: T,
    /// Damping c.
    pub c: T,
}

impl<T: Real> VectorField<T> for ForcedOscillator<T> {
    type Record = ();
    fn dim(&self) -> usize {
        2
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        dydt[0] = y[1];
        dydt[1] = -(T::ONE + self.a * (self.w * t).sin()) * y[0] - self.c * y[1];
    }
    fn vjp(&mut self, t: T, y: &[T], v: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let (s, c) = (self.w * t).sin_cos();
        d_y[0] += -(T::ONE + self.a * s) * v[1];
        d_y[1] += v[0] - self.c * v[1];
        d_params[0] += -s * y[0] * v[1];
        d_params[1] += -self.a * c * t * y[0] * v[1];
        d_params[2] += -y[1] * v[1];
    }
}

/// Why [`by_name`] could not build a problem.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ProblemError {
    /// Not one of the five names.
    UnknownName,
    /// A parameter is missing or has the wrong number of entries.
    Parameter(&'static str),
}

impl core::fmt::Display for ProblemError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::UnknownName => f.write_str(
                "unknown problem (expected van_der_pol, kepler, lorenz, rigid_body, \
                 forced_oscillator)",
            ),
            Self::Parameter(p) => write!(f, "parameter `{p}` missing or of the wrong size"),
        }
    }
}

impl core::error::Error for ProblemError {}

/// Builds a problem of the adaptive reference file from its name and parameters:
/// `van_der_pol` (`mu`), `kepler` (μ = 1; its `e` only sets the initial state),
/// `lorenz` (`sigma`, `rho`, `beta`), `rigid_body` (`inertia`, 3 entries: [`EulerRates`]),
/// `forced_oscillator` (`a`, `w`, `c`). `param(name)` returns a parameter's entries.
///
/// # Errors
/// [`ProblemError`] for an unknown name or a missing parameter.
///
/// ```
/// use evogs_ode::VectorField;
/// use evogs_ode::problems::by_name;
/// let mut f = by_name("lorenz", &|p: &str| match p {
///     "sigma" => Some(vec![10.0]),
///     "rho" => Some(vec![28.0]),
///     "beta" => Some(vec![8.0 / 3.0]),
///     _ => None,
/// })
/// .unwrap();
/// let mut d = [0.0; 3];
/// f.eval(0.0, &[1.0, 1.0, 1.0], &mut d);
/// assert_eq!(d[0], 0.0);
/// ```
pub fn by_name(
    name: &str,
    param: &dyn Fn(&str) -> Option<Vec<f64>>,
) -> Result<Box<dyn VectorField<f64, Record = ()>>, ProblemError> {
    let scalar = |p: &'static str| match param(p).as_deref() {
        Some(&[v]) => Ok(v),
        _ => Err(ProblemError::Parameter(p)),
    };
    Ok(match name {
        "van_der_pol" => Box::new(VanDerPol { mu: scalar("mu")? }),
        "kepler" => Box::new(Kepler::<f64>::default()),
        "lorenz" => Box::new(Lorenz {
            sigma: scalar("sigma")?,
            rho: scalar("rho")?,
            beta: scalar("beta")?,
        }),
        "rigid_body" => match param("inertia").as_deref() {
            Some(&[a, b, c]) => Box::new(EulerRates { inertia: [a, b, c] }),
            _ => return Err(ProblemError::Parameter("inertia")),
        },
        "forced_oscillator" => Box::new(ForcedOscillator {
            a: scalar("a")?,
            w: scalar("w")?,
            c: scalar("c")?,
        }),
        _ => return Err(ProblemError::UnknownName),
    })
}
