//! The embedded Runge–Kutta pairs: [`Pair`] (Dormand–Prince 5(4), Bogacki–Shampine 3(2)),
//! with exact rational coefficients, their continuous extensions and the order conditions
//! up to order 5 ([`weights_order`]).
//!
//! A pair shares the stages of one explicit tableau between two weight vectors: `b` (the
//! propagated solution, order p) and `b̂` (the embedded one, order p − 1). Both pairs here
//! are FSAL: the last row of `a` is `b`, so the last stage is `f(t_{n+1}, y_{n+1})` and is
//! the next step's first stage; a step costs s − 1 field evaluations. The continuous
//! extension replaces `b` by polynomials `bᵢ(θ)` with `bᵢ(0) = 0` and `bᵢ(1) = bᵢ`:
//! `y(tₙ + θh) = yₙ ⊕ h Σ bᵢ(θ)Kᵢ`. See docs/adaptive.md.

use crate::{MAX_STAGES, OrderCondition, Rational, Tableau};
use core::fmt;
use core::str::FromStr;

const fn r(n: i64, d: i64) -> Rational {
    Rational::new(n, d)
}
const Z: Rational = Rational::ZERO;

/// Dormand–Prince 5(4) (Hairer's `DOPRI5`, scipy's `RK45`, torchdiffeq's `dopri5`): 7 stages,
/// FSAL, the 5th-order solution propagated.
const DOPRI5: Tableau = Tableau::new_const(
    "dopri5",
    7,
    [
        r(0, 1),
        r(1, 5),
        r(3, 10),
        r(4, 5),
        r(8, 9),
        r(1, 1),
        r(1, 1),
    ],
    [
        [Z; 7],
        [r(1, 5), Z, Z, Z, Z, Z, Z],
        [r(3, 40), r(9, 40), Z, Z, Z, Z, Z],
        [r(44, 45), r(-56, 15), r(32, 9), Z, Z, Z, Z],
        [
            r(19372, 6561),
            r(-25360, 2187),
            r(64448, 6561),
            r(-212, 729),
            Z,
            Z,
            Z,
        ],
        [
            r(9017, 3168),
            r(-355, 33),
            r(46732, 5247),
            r(49, 176),
            r(-5103, 18656),
            Z,
            Z,
        ],
        [
            r(35, 384),
            Z,
            r(500, 1113),
            r(125, 192),
            r(-2187, 6784),
            r(11, 84),
            Z,
        ],
    ],
    [
        r(35, 384),
        Z,
        r(500, 1113),
        r(125, 192),
        r(-2187, 6784),
        r(11, 84),
        Z,
    ],
);

/// The embedded 4th-order weights of Dormand–Prince.
const DOPRI5_BHAT: [Rational; MAX_STAGES] = [
    r(5179, 57600),
    Z,
    r(7571, 16695),
    r(393, 640),
    r(-92097, 339200),
    r(187, 2100),
    r(1, 40),
];

/// Shampine's 4th-order continuous extension of Dormand–Prince (the one of Hairer's
/// `CONTD5` and scipy's `RK45.P`): `bᵢ(θ) = Σₖ P[i][k] θ^{k+1}`.
const DOPRI5_DENSE: [[Rational; 4]; MAX_STAGES] = [
    [
        r(1, 1),
        r(-8_048_581_381, 2_820_520_608),
        r(8_663_915_743, 2_820_520_608),
        r(-12_715_105_075, 11_282_082_432),
    ],
    [Z, Z, Z, Z],
    [
        Z,
        r(131_558_114_200, 32_700_410_799),
        r(-68_118_460_800, 10_900_136_933),
        r(87_487_479_700, 32_700_410_799),
    ],
    [
        Z,
        r(-1_754_552_775, 470_086_768),
        r(14_199_869_525, 1_410_260_304),
        r(-10_690_763_975, 1_880_347_072),
    ],
    [
        Z,
        r(127_303_824_393, 49_829_197_408),
        r(-318_862_633_887, 49_829_197_408),
        r(701_980_252_875, 199_316_789_632),
    ],
    [
        Z,
        r(-282_668_133, 205_662_961),
        r(2_019_193_451, 616_988_883),
        r(-1_453_857_185, 822_651_844),
    ],
    [
        Z,
        r(40_617_522, 29_380_423),
        r(-110_615_467, 29_380_423),
        r(69_997_945, 29_380_423),
    ],
];

/// Bogacki–Shampine 3(2) (scipy's `RK23`, torchdiffeq's `bosh3`): 4 stages, FSAL, the
/// 3rd-order solution propagated.
const BS32: Tableau = Tableau::new_const(
    "bs32",
    4,
    [r(0, 1), r(1, 2), r(3, 4), r(1, 1)],
    [
        [Z; 4],
        [r(1, 2), Z, Z, Z],
        [Z, r(3, 4), Z, Z],
        [r(2, 9), r(1, 3), r(4, 9), Z],
    ],
    [r(2, 9), r(1, 3), r(4, 9), Z],
);

/// The embedded 2nd-order weights of Bogacki–Shampine.
const BS32_BHAT: [Rational; MAX_STAGES] = [r(7, 24), r(1, 4), r(1, 3), r(1, 8), Z, Z, Z];

/// The cubic Hermite interpolant through `(yₙ, hK₀)` and `(y_{n+1}, hK₃)`, written in the
/// stages: `bᵢ(θ) = (3θ² − 2θ³)bᵢ + (θ − 2θ² + θ³)δᵢ₀ + (θ³ − θ²)δᵢ₃` (3rd order; scipy's
/// `RK23.P`).
const BS32_DENSE: [[Rational; 4]; MAX_STAGES] = [
    [r(1, 1), r(-4, 3), r(5, 9), Z],
    [Z, r(1, 1), r(-2, 3), Z],
    [Z, r(4, 3), r(-8, 9), Z],
    [Z, r(-1, 1), r(1, 1), Z],
    [Z; 4],
    [Z; 4],
    [Z; 4],
];

/// An embedded explicit Runge–Kutta pair with a continuous extension.
///
/// | pair | stages (FSAL) | propagated | embedded | dense output | evaluations per step |
/// |---|---|---|---|---|---|
/// | `Dopri5` | 7 | 5 | 4 | 4 (Shampine) | 6 |
/// | `Bs32` | 4 | 3 | 2 | 3 (Hermite) | 3 |
///
/// Names (`FromStr`/`Display`): `"dopri5"` (also `"dp5"`, `"rk45"`, `"dopri45"`) and
/// `"bs32"` (also `"bs3"`, `"rk23"`, `"bosh3"`).
///
/// ```
/// use evogs_ode::adaptive::{Pair, weights_order};
/// let p: Pair = "rk45".parse().unwrap();
/// assert_eq!(p, Pair::Dopri5);
/// let t = p.tableau();
/// assert!(t.is_fsal());
/// assert_eq!(weights_order(&t, &p.embedded_weights()), 4);
/// assert_eq!(weights_order(&t, &t.weights()), 5);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Pair {
    /// Dormand–Prince 5(4); the default.
    #[default]
    Dopri5,
    /// Bogacki–Shampine 3(2).
    Bs32,
}

impl Pair {
    /// Both pairs.
    pub const ALL: [Self; 2] = [Self::Dopri5, Self::Bs32];

    /// The tableau with the propagated weights `b` (FSAL).
    #[must_use]
    pub const fn tableau(self) -> Tableau {
        match self {
            Self::Dopri5 => DOPRI5,
            Self::Bs32 => BS32,
        }
    }

    /// The embedded weights `b̂` ([`MAX_STAGES`] entries, zero beyond the stages).
    #[must_use]
    pub const fn embedded_weights(self) -> [Rational; MAX_STAGES] {
        match self {
            Self::Dopri5 => DOPRI5_BHAT,
            Self::Bs32 => BS32_BHAT,
        }
    }

    /// The same stages with the embedded weights `b̂` as a tableau (to step with the
    /// embedded solution alone, e.g. to measure its order).
    #[must_use]
    pub fn embedded_tableau(self) -> Tableau {
        let t = self.tableau();
        let s = t.stages();
        let mut c = [Z; MAX_STAGES];
        let mut a = [[Z; MAX_STAGES]; MAX_STAGES];
        for i in 0..s {
            c[i] = t.c(i);
            for j in 0..i {
                a[i][j] = t.a(i, j);
            }
        }
        let name = match self {
            Self::Dopri5 => "dopri5-embedded",
            Self::Bs32 => "bs32-embedded",
        };
        Tableau::new_const(name, s, c, a, self.embedded_weights())
    }

    /// The continuous extension: `bᵢ(θ) = Σₖ P[i][k] θ^{k+1}` (degree ≤ 4).
    #[must_use]
    pub const fn dense_coefficients(self) -> [[Rational; 4]; MAX_STAGES] {
        match self {
            Self::Dopri5 => DOPRI5_DENSE,
            Self::Bs32 => BS32_DENSE,
        }
    }

    /// Order of the propagated solution (5, 3).
    #[must_use]
    pub const fn order(self) -> usize {
        match self {
            Self::Dopri5 => 5,
            Self::Bs32 => 3,
        }
    }

    /// Order of the embedded solution (4, 2): the local error estimate is `O(h^{q+1})`
    /// with this `q`, which sets the controller's exponents.
    #[must_use]
    pub const fn embedded_order(self) -> usize {
        match self {
            Self::Dopri5 => 4,
            Self::Bs32 => 2,
        }
    }

    /// Order of the continuous extension (4, 3).
    #[must_use]
    pub const fn dense_order(self) -> usize {
        match self {
            Self::Dopri5 => 4,
            Self::Bs32 => 3,
        }
    }

    /// Number of stages (7, 4).
    #[must_use]
    pub const fn stages(self) -> usize {
        self.tableau().stages()
    }

    /// The canonical name (`"dopri5"`, `"bs32"`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        self.tableau().name()
    }
}

impl fmt::Display for Pair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The error of parsing an unknown pair name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParsePairError;

impl fmt::Display for ParsePairError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("unknown adaptive pair (expected dopri5 or bs32)")
    }
}

impl core::error::Error for ParsePairError {}

impl FromStr for Pair {
    type Err = ParsePairError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        const NAMES: [(&str, Pair); 8] = [
            ("dopri5", Pair::Dopri5),
            ("dp5", Pair::Dopri5),
            ("rk45", Pair::Dopri5),
            ("dopri45", Pair::Dopri5),
            ("bs32", Pair::Bs32),
            ("bs3", Pair::Bs32),
            ("rk23", Pair::Bs32),
            ("bosh3", Pair::Bs32),
        ];
        let s = s.trim();
        NAMES
            .iter()
            .find(|(name, _)| name.eq_ignore_ascii_case(s))
            .map(|&(_, p)| p)
            .ok_or(ParsePairError)
    }
}

/// The 17 rooted-tree order conditions up to order 5 of the stages of `tableau` with the
/// weights `w` (its own `b`, or an embedded `b̂`), evaluated exactly.
///
/// Orders 1–4 are the 8 conditions of [`Tableau::order_conditions`]; order 5 adds the nine
/// trees `Σwc⁴ = 1/5`, `Σwc²(Ac) = 1/10`, `Σwc(Ac²) = 1/15`, `Σwc(A²c) = 1/30`,
/// `Σw(Ac)² = 1/20`, `wᵀAc³ = 1/20`, `wᵀA(c·Ac) = 1/40`, `wᵀA²c² = 1/60`, `wᵀA³c = 1/120`.
#[must_use]
pub fn order_conditions_5(tableau: &Tableau, w: &[Rational]) -> [OrderCondition; 17] {
    type V = [Rational; MAX_STAGES];
    let s = tableau.stages();
    let dot = |u: &V, v: &V| (0..s).fold(Z, |acc, i| acc + u[i] * v[i]);
    let amul = |v: &V| {
        let mut out = [Z; MAX_STAGES];
        for (i, o) in out.iter_mut().enumerate().take(s) {
            *o = (0..i).fold(Z, |acc, j| acc + tableau.a(i, j) * v[j]);
        }
        out
    };
    let elem = |u: &V, v: &V| {
        let mut out = [Z; MAX_STAGES];
        for i in 0..s {
            out[i] = u[i] * v[i];
        }
        out
    };
    let mut b = [Z; MAX_STAGES];
    for (bi, wi) in b.iter_mut().zip(w).take(s) {
        *bi = *wi;
    }
    let one = [Rational::ONE; MAX_STAGES];
    let mut c = [Z; MAX_STAGES];
    for (i, ci) in c.iter_mut().enumerate().take(s) {
        *ci = tableau.c(i);
    }
    let c2 = elem(&c, &c);
    let c3 = elem(&c2, &c);
    let c4 = elem(&c3, &c);
    let ac = amul(&c);
    let ac2 = amul(&c2);
    let aac = amul(&ac);
    let cond = |order, tree, value, target| OrderCondition {
        order,
        tree,
        value,
        target,
    };
    [
        cond(1, "Σb", dot(&b, &one), r(1, 1)),
        cond(2, "Σbc", dot(&b, &c), r(1, 2)),
        cond(3, "Σbc²", dot(&b, &c2), r(1, 3)),
        cond(3, "bᵀAc", dot(&b, &ac), r(1, 6)),
        cond(4, "Σbc³", dot(&b, &c3), r(1, 4)),
        cond(4, "Σb·c·Ac", dot(&b, &elem(&c, &ac)), r(1, 8)),
        cond(4, "bᵀAc²", dot(&b, &ac2), r(1, 12)),
        cond(4, "bᵀA²c", dot(&b, &aac), r(1, 24)),
        cond(5, "Σbc⁴", dot(&b, &c4), r(1, 5)),
        cond(5, "Σb·c²·Ac", dot(&b, &elem(&c2, &ac)), r(1, 10)),
        cond(5, "Σb·c·Ac²", dot(&b, &elem(&c, &ac2)), r(1, 15)),
        cond(5, "Σb·c·A²c", dot(&b, &elem(&c, &aac)), r(1, 30)),
        cond(5, "Σb·(Ac)²", dot(&b, &elem(&ac, &ac)), r(1, 20)),
        cond(5, "bᵀAc³", dot(&b, &amul(&c3)), r(1, 20)),
        cond(5, "bᵀA(c·Ac)", dot(&b, &amul(&elem(&c, &ac))), r(1, 40)),
        cond(5, "bᵀA²c²", dot(&b, &amul(&ac2)), r(1, 60)),
        cond(5, "bᵀA³c", dot(&b, &amul(&aac)), r(1, 120)),
    ]
}

/// The classical order (0..=5) of the stages of `tableau` with weights `w`: the largest p
/// such that every condition of order ≤ p holds exactly (0 if the nodes are not the row
/// sums of `a`).
#[must_use]
pub fn weights_order(tableau: &Tableau, w: &[Rational]) -> usize {
    if !tableau.row_sums_match() {
        return 0;
    }
    let conds = order_conditions_5(tableau, w);
    (1..=5)
        .take_while(|&p| {
            conds
                .iter()
                .filter(|c| c.order == p)
                .all(OrderCondition::holds)
        })
        .last()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Σᵢ P[i][k]·φᵢ` for every power `θ^{k+1}`.
    fn dense_dot(p: &[[Rational; 4]; MAX_STAGES], phi: &[Rational]) -> [Rational; 4] {
        let mut out = [Z; 4];
        for (k, o) in out.iter_mut().enumerate() {
            *o = (0..phi.len()).fold(Z, |acc, i| acc + p[i][k] * phi[i]);
        }
        out
    }

    #[test]
    fn pairs_have_their_orders_exactly() {
        for pair in Pair::ALL {
            let t = pair.tableau();
            assert!(t.row_sums_match(), "{pair}: c = row sums");
            assert!(t.is_fsal(), "{pair}: FSAL");
            assert_eq!(weights_order(&t, &t.weights()), pair.order(), "{pair} b");
            assert_eq!(
                weights_order(&t, &pair.embedded_weights()),
                pair.embedded_order(),
                "{pair} b̂"
            );
            let e = pair.embedded_tableau();
            assert!(!e.is_fsal(), "{pair}: the embedded tableau is not FSAL");
            assert_eq!(e.order(), pair.embedded_order(), "{pair}: embedded tableau");
            assert_eq!(pair.name().parse::<Pair>(), Ok(pair), "name round trip");
            assert_eq!(pair.to_string(), pair.name(), "Display is the name");
        }
        assert_eq!("rk4".parse::<Pair>(), Err(ParsePairError), "unknown name");
        assert_eq!(
            ParsePairError.to_string(),
            "unknown adaptive pair (expected dopri5 or bs32)"
        );
    }

    #[test]
    fn continuous_extensions_meet_their_conditions_exactly() {
        for pair in Pair::ALL {
            let t = pair.tableau();
            let s = t.stages();
            let p = pair.dense_coefficients();
            // bᵢ(1) = bᵢ, b'(0) = e₀ (K₀ = f(yₙ)), b'(1) = e_{s−1} (K_{s−1} = f(y_{n+1})).
            for i in 0..s {
                let at1 = p[i].iter().fold(Z, |a, &x| a + x);
                assert_eq!(at1, t.b(i), "{pair}: b_{i}(1)");
                let d1 = (0..4).fold(Z, |a, k| a + Rational::int(k as i64 + 1) * p[i][k]);
                let want = if i == s - 1 { Rational::ONE } else { Z };
                assert_eq!(d1, want, "{pair}: b'_{i}(1)");
                assert_eq!(p[i][0], if i == 0 { Rational::ONE } else { Z }, "b'(0)");
            }
            // Order conditions of the extension, as polynomials in θ:
            // Σbᵢ(θ)φᵢ(τ) = θ^{|τ|}/γ(τ) for every tree up to the dense order.
            let c: alloc::vec::Vec<Rational> = (0..s).map(|i| t.c(i)).collect();
            let ac: alloc::vec::Vec<Rational> = (0..s)
                .map(|i| (0..i).fold(Z, |a, j| a + t.a(i, j) * c[j]))
                .collect();
            let sq = |v: &[Rational]| v.iter().map(|&x| x * x).collect::<alloc::vec::Vec<_>>();
            let amul = |v: &[Rational]| {
                (0..s)
                    .map(|i| (0..i).fold(Z, |a, j| a + t.a(i, j) * v[j]))
                    .collect::<alloc::vec::Vec<_>>()
            };
            let one = alloc::vec![Rational::ONE; s];
            let c2 = sq(&c);
            let c3: alloc::vec::Vec<_> = c2.iter().zip(&c).map(|(&a, &b)| a * b).collect();
            let c_ac: alloc::vec::Vec<_> = c.iter().zip(&ac).map(|(&a, &b)| a * b).collect();
            let trees: [(usize, alloc::vec::Vec<Rational>, Rational); 8] = [
                (1, one, r(1, 1)),
                (2, c.clone(), r(1, 2)),
                (3, c2.clone(), r(1, 3)),
                (3, ac.clone(), r(1, 6)),
                (4, c3, r(1, 4)),
                (4, c_ac, r(1, 8)),
                (4, amul(&c2), r(1, 12)),
                (4, amul(&ac), r(1, 24)),
            ];
            // The extension's order is exactly the documented one (up to 4, the trees here):
            // every tree up to it holds, and one of the next order (if listed) fails.
            let holds = |(order, phi, target): &(usize, alloc::vec::Vec<Rational>, Rational)| {
                let got = dense_dot(&p, phi);
                (0..4).all(|k| got[k] == if k + 1 == *order { *target } else { Z })
            };
            let met = (1..=4)
                .take_while(|&o| trees.iter().filter(|t| t.0 == o).all(holds))
                .last()
                .unwrap_or(0);
            assert_eq!(met, pair.dense_order(), "{pair}: dense order");
        }
    }
}
