//! The built-in integration methods: [`Method`].

use crate::Tableau;
use core::fmt;
use core::str::FromStr;

/// A built-in explicit Runge–Kutta method.
///
/// Every method runs through the same stepper core; on SO(3) and SE(3) blocks that core is
/// the left-trivialised Runge–Kutta–Munthe-Kaas method with the same tableau, so (SE(3)
/// blocks alike, with `T ← Exp(hξ)T`):
///
/// | method | Euclidean blocks | SO(3) blocks | order |
/// |---|---|---|---|
/// | `Euler` | forward Euler | **Lie–Euler** `R ← Exp(hω)R` | 1 |
/// | `Midpoint` | explicit midpoint | RKMK midpoint | 2 |
/// | `Heun` | Heun (trapezoidal) | RKMK Heun | 2 |
/// | `Rk4` | classical RK4 | **RKMK4** | 4 |
/// | `Rk38` | RK4 3/8 rule | RKMK with the 3/8 tableau | 4 |
///
/// Names (`FromStr`/`Display`): `"euler"`, `"midpoint"`, `"heun"`, `"rk4"`, `"rk38"`; the
/// oracle's names `"rk4_classic"` and `"rk4_38"` (and `"lie_euler"`, `"rkmk4"`) are also
/// accepted. Note that torchdiffeq's `"rk4"` is the 3/8 rule.
///
/// ```
/// use evogs_ode::Method;
/// let m: Method = "rk4_38".parse().unwrap();
/// assert_eq!(m, Method::Rk38);
/// assert_eq!(m.to_string(), "rk38");
/// assert_eq!(Method::Rk4.order(), 4);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Method {
    /// Forward Euler / Lie–Euler (order 1).
    Euler,
    /// Explicit midpoint (order 2).
    Midpoint,
    /// Heun's method (order 2).
    Heun,
    /// Classical RK4 / RKMK4 (order 4); the default.
    #[default]
    Rk4,
    /// RK4 3/8 rule (order 4).
    Rk38,
}

impl Method {
    /// Every built-in method, in increasing order.
    pub const ALL: [Self; 5] = [
        Self::Euler,
        Self::Midpoint,
        Self::Heun,
        Self::Rk4,
        Self::Rk38,
    ];

    /// The Butcher tableau.
    #[must_use]
    pub const fn tableau(self) -> Tableau {
        match self {
            Self::Euler => Tableau::EULER,
            Self::Midpoint => Tableau::MIDPOINT,
            Self::Heun => Tableau::HEUN,
            Self::Rk4 => Tableau::RK4,
            Self::Rk38 => Tableau::RK38,
        }
    }

    /// The classical order (also the order on SO(3) and SE(3) blocks).
    #[must_use]
    pub const fn order(self) -> usize {
        match self {
            Self::Euler => 1,
            Self::Midpoint | Self::Heun => 2,
            Self::Rk4 | Self::Rk38 => 4,
        }
    }

    /// Number of field evaluations per step.
    #[must_use]
    pub const fn stages(self) -> usize {
        self.tableau().stages()
    }

    /// The canonical name (`"euler"`, `"midpoint"`, `"heun"`, `"rk4"`, `"rk38"`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        self.tableau().name()
    }
}

impl From<Method> for Tableau {
    fn from(m: Method) -> Self {
        m.tableau()
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The error of parsing an unknown method name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParseMethodError;

impl fmt::Display for ParseMethodError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("unknown method (expected euler, midpoint, heun, rk4, rk38)")
    }
}

impl core::error::Error for ParseMethodError {}

impl FromStr for Method {
    type Err = ParseMethodError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        const NAMES: [(&str, Method); 11] = [
            ("euler", Method::Euler),
            ("lie_euler", Method::Euler),
            ("lie-euler", Method::Euler),
            ("midpoint", Method::Midpoint),
            ("heun", Method::Heun),
            ("rk4", Method::Rk4),
            ("rk4_classic", Method::Rk4),
            ("rkmk4", Method::Rk4),
            ("rk38", Method::Rk38),
            ("rk4_38", Method::Rk38),
            ("rk4-38", Method::Rk38),
        ];
        let s = s.trim();
        NAMES
            .iter()
            .find(|(name, _)| name.eq_ignore_ascii_case(s))
            .map(|&(_, m)| m)
            .ok_or(ParseMethodError)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::ToString;

    #[test]
    fn names_round_trip_and_orders_match_the_tableaux() {
        for m in Method::ALL {
            let back: Method = m.to_string().parse().expect("own name parses");
            assert_eq!(back, m, "round trip");
            assert_eq!(m.order(), m.tableau().order(), "{m}: order() = exact order");
        }
        assert_eq!(
            "RK4_CLASSIC".parse::<Method>(),
            Ok(Method::Rk4),
            "oracle name"
        );
        assert!("rk5".parse::<Method>().is_err(), "unknown name");
    }

    #[test]
    fn the_parse_error_lists_the_names() {
        let msg = "rk5".parse::<Method>().unwrap_err().to_string();
        for m in Method::ALL {
            assert!(msg.contains(m.name()), "{msg:?} names {m}");
        }
    }
}
