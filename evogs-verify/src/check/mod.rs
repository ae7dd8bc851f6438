//! Self-verification reports: `evogs check-order` ([`order`]: measured convergence orders of
//! every stepper) and `evogs check-grad` ([`grad`]: every VJP of the stack and the
//! end-to-end training step against central differences in f64).

pub mod grad;
pub mod order;
