//! evogs-ode (skeleton).
#![cfg_attr(not(feature = "std"), no_std)]
