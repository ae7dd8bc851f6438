//! Explicit Runge–Kutta tableaux with exact rational entries, their order conditions and
//! stability polynomials.
//!
//! An explicit s-stage method (`docs/integrators.md` §2) steps from `(tₙ, yₙ)` with step `h`:
//!
//! ```text
//! Xᵢ = yₙ + h Σ_{j<i} a_ij Kⱼ,   Kᵢ = f(tₙ + cᵢh, Xᵢ),   y_{n+1} = yₙ + h Σᵢ bᵢKᵢ
//! ```
//!
//! Up to order 4 there are 8 rooted-tree conditions (with the row sums `cᵢ = Σⱼ a_ij`):
//!
//! ```text
//! order 1:  Σb = 1
//! order 2:  Σbc = 1/2
//! order 3:  Σbc² = 1/3,  bᵀAc = 1/6
//! order 4:  Σbc³ = 1/4,  Σb·c·(Ac) = 1/8,  bᵀAc² = 1/12,  bᵀA²c = 1/24
//! ```
//!
//! [`Tableau::order`] checks them in exact [`Rational`] arithmetic. On the linear problem
//! `y' = λy` one step is exactly `y ↦ R(hλ)y` with the stability polynomial
//! `R(z) = Σₖ γₖ zᵏ`, `γ₀ = 1`, `γₖ = bᵀA^{k−1}𝟙` ([`Tableau::stability_coefficients`]):
//! that only sees the "tall trees", which is why order tests need nonlinear and
//! non-autonomous problems too.

use crate::Rational;
use evogs_math::Real;

/// The largest number of stages of a [`Tableau`].
pub const MAX_STAGES: usize = 7;

/// An explicit Runge–Kutta tableau (at most [`MAX_STAGES`] stages), entries exact.
///
/// `a` is strictly lower triangular (explicit method). The same tableau drives Euclidean
/// blocks and, through the left-trivialised RKMK construction, SO(3) blocks
/// (see [`Stepper`](crate::Stepper)).
///
/// ```
/// use evogs_ode::{Method, Rational, Tableau};
/// let rk4 = Method::Rk4.tableau();
/// assert_eq!(rk4.order(), 4);
/// assert_eq!(rk4.stability_coefficients()[4], Rational::new(1, 24));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tableau {
    name: &'static str,
    stages: usize,
    c: [Rational; MAX_STAGES],
    a: [[Rational; MAX_STAGES]; MAX_STAGES],
    b: [Rational; MAX_STAGES],
}

/// The residual of one order condition: `value − target` (zero when satisfied).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderCondition {
    /// The order the condition belongs to (1..=4).
    pub order: usize,
    /// A short name of the rooted tree, e.g. `"Σbc²"`.
    pub tree: &'static str,
    /// The tableau's value of the elementary weight.
    pub value: Rational,
    /// The value required for that order (`1/γ(tree)`).
    pub target: Rational,
}

impl OrderCondition {
    /// `true` if `value == target` exactly.
    #[must_use]
    pub fn holds(&self) -> bool {
        self.value == self.target
    }
}

const fn r(n: i64, d: i64) -> Rational {
    Rational::new(n, d)
}
const Z: Rational = Rational::ZERO;

impl Tableau {
    /// Forward Euler: `c = [0]`, `b = [1]`.
    pub const EULER: Self = Self::new_const(
        "euler",
        1,
        [Z, Z, Z, Z],
        [[Z; 4], [Z; 4], [Z; 4], [Z; 4]],
        [r(1, 1), Z, Z, Z],
    );
    /// Explicit midpoint: `c = [0, 1/2]`, `a21 = 1/2`, `b = [0, 1]`.
    pub const MIDPOINT: Self = Self::new_const(
        "midpoint",
        2,
        [Z, r(1, 2), Z, Z],
        [[Z; 4], [r(1, 2), Z, Z, Z], [Z; 4], [Z; 4]],
        [Z, r(1, 1), Z, Z],
    );
    /// Heun (explicit trapezoidal): `c = [0, 1]`, `a21 = 1`, `b = [1/2, 1/2]`.
    pub const HEUN: Self = Self::new_const(
        "heun",
        2,
        [Z, r(1, 1), Z, Z],
        [[Z; 4], [r(1, 1), Z, Z, Z], [Z; 4], [Z; 4]],
        [r(1, 2), r(1, 2), Z, Z],
    );
    /// Classical RK4: `c = [0, 1/2, 1/2, 1]`, `a21 = a32 = 1/2`, `a43 = 1`,
    /// `b = [1/6, 1/3, 1/3, 1/6]`.
    pub const RK4: Self = Self::new_const(
        "rk4",
        4,
        [Z, r(1, 2), r(1, 2), r(1, 1)],
        [
            [Z; 4],
            [r(1, 2), Z, Z, Z],
            [Z, r(1, 2), Z, Z],
            [Z, Z, r(1, 1), Z],
        ],
        [r(1, 6), r(1, 3), r(1, 3), r(1, 6)],
    );
    /// Kutta's RK4 "3/8 rule" (what torchdiffeq calls `rk4`): `c = [0, 1/3, 2/3, 1]`,
    /// `a21 = 1/3`, `a31 = −1/3`, `a32 = 1`, `a41 = 1`, `a42 = −1`, `a43 = 1`,
    /// `b = [1/8, 3/8, 3/8, 1/8]`.
    pub const RK38: Self = Self::new_const(
        "rk38",
        4,
        [Z, r(1, 3), r(2, 3), r(1, 1)],
        [
            [Z; 4],
            [r(1, 3), Z, Z, Z],
            [r(-1, 3), r(1, 1), Z, Z],
            [r(1, 1), r(-1, 1), r(1, 1), Z],
        ],
        [r(1, 8), r(3, 8), r(3, 8), r(1, 8)],
    );

    /// A tableau from `N`-entry arrays (`N ≤ MAX_STAGES`), padded with zeros.
    pub(crate) const fn new_const<const N: usize>(
        name: &'static str,
        stages: usize,
        c: [Rational; N],
        a: [[Rational; N]; N],
        b: [Rational; N],
    ) -> Self {
        assert!(N <= MAX_STAGES && stages <= N, "too many stages");
        let mut t = Self {
            name,
            stages,
            c: [Z; MAX_STAGES],
            a: [[Z; MAX_STAGES]; MAX_STAGES],
            b: [Z; MAX_STAGES],
        };
        let mut i = 0;
        while i < N {
            t.c[i] = c[i];
            t.b[i] = b[i];
            let mut j = 0;
            while j < N {
                t.a[i][j] = a[i][j];
                j += 1;
            }
            i += 1;
        }
        t
    }

    /// A user tableau with `stages = b.len()` stages; `a[i]` holds the entries
    /// `a_i0 … a_{i,i−1}` of row `i` (row 0 is empty).
    ///
    /// Returns `None` if `stages` is 0 or above [`MAX_STAGES`], if `c` has another length,
    /// or if row `i` of `a` does not have exactly `i` entries (explicit methods only).
    ///
    /// ```
    /// use evogs_ode::{Rational as R, Tableau};
    /// // Kutta's third-order method.
    /// let k3 = Tableau::new(
    ///     "kutta3",
    ///     &[R::ZERO, R::new(1, 2), R::ONE],
    ///     &[&[], &[R::new(1, 2)], &[R::int(-1), R::int(2)]],
    ///     &[R::new(1, 6), R::new(2, 3), R::new(1, 6)],
    /// ).unwrap();
    /// assert_eq!(k3.order(), 3);
    /// ```
    #[must_use]
    pub fn new(
        name: &'static str,
        c: &[Rational],
        a: &[&[Rational]],
        b: &[Rational],
    ) -> Option<Self> {
        let s = b.len();
        if s == 0 || s > MAX_STAGES || c.len() != s || a.len() != s {
            return None;
        }
        let mut t = Self::new_const(name, 0, [Z; 1], [[Z; 1]; 1], [Z; 1]);
        t.stages = s;
        for i in 0..s {
            if a[i].len() != i {
                return None;
            }
            t.c[i] = c[i];
            t.b[i] = b[i];
            t.a[i][..i].copy_from_slice(a[i]);
        }
        Some(t)
    }

    /// The tableau's name (`"euler"`, `"rk4"`, … or the user's).
    #[must_use]
    pub const fn name(&self) -> &'static str {
        self.name
    }

    /// Number of stages s.
    #[must_use]
    pub const fn stages(&self) -> usize {
        self.stages
    }

    /// Node `cᵢ` (0-based stage index).
    #[must_use]
    pub const fn c(&self, i: usize) -> Rational {
        self.c[i]
    }

    /// Coupling `a_ij` (0-based; zero unless `j < i`).
    #[must_use]
    pub const fn a(&self, i: usize, j: usize) -> Rational {
        self.a[i][j]
    }

    /// Weight `bᵢ`.
    #[must_use]
    pub const fn b(&self, i: usize) -> Rational {
        self.b[i]
    }

    /// The weights `b` ([`MAX_STAGES`] entries, zero beyond the stages).
    #[must_use]
    pub const fn weights(&self) -> [Rational; MAX_STAGES] {
        self.b
    }

    /// `true` for a "first same as last" tableau: the last row of `a` is `b`, the last node
    /// is 1 and the last weight is 0, so the last stage is the field at the new state; the
    /// first node is 0, so the next step's first stage is the field there too and can be
    /// taken from it (Dormand–Prince, Bogacki–Shampine).
    #[must_use]
    pub fn is_fsal(&self) -> bool {
        let s = self.stages;
        s > 1
            && self.c[0].is_zero()
            && self.c[s - 1] == Rational::ONE
            && self.b[s - 1].is_zero()
            && (0..s - 1).all(|j| self.a[s - 1][j] == self.b[j])
    }

    /// `true` if every node equals its row sum, `cᵢ = Σⱼ a_ij` (needed for the tree
    /// conditions below to be the order conditions of non-autonomous problems).
    #[must_use]
    pub fn row_sums_match(&self) -> bool {
        (0..self.stages).all(|i| self.a[i].iter().fold(Z, |acc, &x| acc + x) == self.c[i])
    }

    /// The 8 order conditions up to order 4, evaluated exactly.
    #[must_use]
    pub fn order_conditions(&self) -> [OrderCondition; 8] {
        let s = self.stages;
        let dot = |u: &[Rational; MAX_STAGES], v: &[Rational; MAX_STAGES]| {
            (0..s).fold(Z, |acc, i| acc + u[i] * v[i])
        };
        let amul = |v: &[Rational; MAX_STAGES]| {
            let mut out = [Z; MAX_STAGES];
            for i in 0..s {
                out[i] = (0..s).fold(Z, |acc, j| acc + self.a[i][j] * v[j]);
            }
            out
        };
        let elem = |u: &[Rational; MAX_STAGES], v: &[Rational; MAX_STAGES]| {
            let mut out = [Z; MAX_STAGES];
            for i in 0..s {
                out[i] = u[i] * v[i];
            }
            out
        };
        let one = [Rational::ONE; MAX_STAGES];
        let c = self.c;
        let c2 = elem(&c, &c);
        let c3 = elem(&c2, &c);
        let ac = amul(&c);
        let cond = |order, tree, value, target| OrderCondition {
            order,
            tree,
            value,
            target,
        };
        [
            cond(1, "Σb", dot(&self.b, &one), r(1, 1)),
            cond(2, "Σbc", dot(&self.b, &c), r(1, 2)),
            cond(3, "Σbc²", dot(&self.b, &c2), r(1, 3)),
            cond(3, "bᵀAc", dot(&self.b, &ac), r(1, 6)),
            cond(4, "Σbc³", dot(&self.b, &c3), r(1, 4)),
            cond(4, "Σb·c·Ac", dot(&self.b, &elem(&c, &ac)), r(1, 8)),
            cond(4, "bᵀAc²", dot(&self.b, &amul(&c2)), r(1, 12)),
            cond(4, "bᵀA²c", dot(&self.b, &amul(&ac)), r(1, 24)),
        ]
    }

    /// The classical order (0..=4): the largest p such that every condition of order ≤ p
    /// holds exactly. Returns 0 if the nodes are not the row sums of `a`.
    #[must_use]
    pub fn order(&self) -> usize {
        if !self.row_sums_match() {
            return 0;
        }
        let conds = self.order_conditions();
        (1..=4)
            .take_while(|&p| {
                conds
                    .iter()
                    .filter(|c| c.order == p)
                    .all(OrderCondition::holds)
            })
            .last()
            .unwrap_or(0)
    }

    /// Coefficients `γ₀ … γ₇` of the stability polynomial `R(z) = Σₖ γₖ zᵏ`:
    /// `γ₀ = 1`, `γₖ = bᵀA^{k−1}𝟙` (zero beyond the number of stages; [`MAX_STAGES`] + 1
    /// entries).
    #[must_use]
    pub fn stability_coefficients(&self) -> [Rational; MAX_STAGES + 1] {
        let s = self.stages;
        let mut out = [Z; MAX_STAGES + 1];
        out[0] = Rational::ONE;
        let mut v = [Rational::ONE; MAX_STAGES];
        for slot in out.iter_mut().skip(1) {
            *slot = (0..s).fold(Z, |acc, i| acc + self.b[i] * v[i]);
            let mut next = [Z; MAX_STAGES];
            for i in 0..s {
                next[i] = (0..s).fold(Z, |acc, j| acc + self.a[i][j] * v[j]);
            }
            v = next;
        }
        out
    }

    /// `R(z)`, the factor one step multiplies `y` by on `y' = λy` (`z = hλ`), by Horner.
    #[must_use]
    pub fn stability_function<T: Real>(&self, z: T) -> T {
        self.stability_coefficients()
            .iter()
            .rev()
            .fold(T::ZERO, |acc, g| acc * z + T::from_f64(g.to_f64()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_tableaux_have_their_orders_exactly() {
        for (t, p) in [
            (Tableau::EULER, 1),
            (Tableau::MIDPOINT, 2),
            (Tableau::HEUN, 2),
            (Tableau::RK4, 4),
            (Tableau::RK38, 4),
        ] {
            assert!(t.row_sums_match(), "{}: c = row sums of a", t.name());
            assert_eq!(t.order(), p, "{}: order", t.name());
            let conds = t.order_conditions();
            for cond in conds.iter().filter(|c| c.order <= p) {
                assert!(cond.holds(), "{}: {} = {}", t.name(), cond.tree, cond.value);
            }
            // The next order fails (so `order` is not vacuous), except for order 4.
            if p < 4 {
                assert!(
                    conds.iter().any(|c| c.order == p + 1 && !c.holds()),
                    "{} must fail some order-{} condition",
                    t.name(),
                    p + 1
                );
            }
        }
    }

    #[test]
    fn fsal_needs_every_one_of_its_conditions() {
        // Bogacki–Shampine 3(2): FSAL.
        let (c, b) = (
            [Z, r(1, 2), r(3, 4), r(1, 1)],
            [r(2, 9), r(1, 3), r(4, 9), Z],
        );
        let a: [&[Rational]; 4] = [&[], &[r(1, 2)], &[Z, r(3, 4)], &b[..3]];
        let fsal = |c: &[Rational], a: &[&[Rational]], b: &[Rational]| {
            Tableau::new("t", c, a, b).expect("a tableau").is_fsal()
        };
        assert!(fsal(&c, &a, &b), "Bogacki–Shampine");
        let mut c0 = c;
        c0[0] = r(1, 4);
        assert!(!fsal(&c0, &a, &b), "first node not 0");
        let mut c3 = c;
        c3[3] = r(3, 4);
        assert!(!fsal(&c3, &a, &b), "last node not 1");
        let (mut b3, last) = (b, [r(2, 9), r(1, 3), r(4, 9)]);
        b3[3] = r(1, 9);
        let a3: [&[Rational]; 4] = [&[], &[r(1, 2)], &[Z, r(3, 4)], &last];
        assert!(!fsal(&c, &a3, &b3), "last weight not 0");
        let row = [r(2, 9), r(1, 3), r(1, 2)];
        let a_row: [&[Rational]; 4] = [&[], &[r(1, 2)], &[Z, r(3, 4)], &row];
        assert!(!fsal(&c, &a_row, &b), "last row not b");
        assert!(
            !Tableau::RK4.is_fsal() && !Tableau::EULER.is_fsal(),
            "RK4, Euler"
        );
    }

    #[test]
    fn both_rk4_have_the_taylor_stability_polynomial() {
        let mut want = [Z; MAX_STAGES + 1];
        want[..5].copy_from_slice(&[r(1, 1), r(1, 1), r(1, 2), r(1, 6), r(1, 24)]);
        assert_eq!(Tableau::RK4.stability_coefficients(), want, "classical RK4");
        assert_eq!(Tableau::RK38.stability_coefficients(), want, "3/8 rule");
        let z = -0.3_f64;
        let r4 = 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;
        assert!(
            (Tableau::RK4.stability_function(z) - r4).abs() < 1e-16,
            "R(z)"
        );
    }

    #[test]
    fn the_fake_rk4_is_caught_by_the_exact_conditions() {
        // docs/integrators.md §2: RK4's stability polynomial, but Σbc² = 1/2: order 2.
        let fake = Tableau::new(
            "fake-rk4",
            &[Z, r(1, 1), Z, r(1, 1)],
            &[
                &[],
                &[r(1, 1)],
                &[r(-1, 4), r(1, 4)],
                &[r(-1, 2), r(1, 2), r(1, 1)],
            ],
            &[r(1, 6), r(1, 3), r(1, 3), r(1, 6)],
        )
        .expect("valid explicit tableau");
        assert_eq!(
            fake.stability_coefficients(),
            Tableau::RK4.stability_coefficients(),
            "same R(z) as RK4"
        );
        assert_eq!(fake.order(), 2, "but only order 2");
    }

    #[test]
    fn user_tableaux_are_validated() {
        assert!(Tableau::new("x", &[], &[], &[]).is_none(), "no stages");
        assert!(
            Tableau::new("x", &[Z, Z], &[&[], &[]], &[r(1, 2), r(1, 2)]).is_none(),
            "row 1 needs one entry"
        );
        let inconsistent =
            Tableau::new("x", &[Z, r(1, 2)], &[&[], &[r(1, 1)]], &[Z, r(1, 1)]).expect("shape ok");
        assert_eq!(inconsistent.order(), 0, "c ≠ row sums");
    }
}
