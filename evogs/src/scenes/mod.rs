//! Procedural dynamic scenes with known motion, for measuring prediction (frames after the
//! training window, between sparse training times): Gaussian bodies whose motion is a
//! closed-form law of `t`, over a static checkerboard floor, rendered by evogs's own
//! rasterizer into the D-NeRF layout with the ground truth beside (`motion.json`) and a
//! motion mask per frame. `docs/scenes.md` describes the scenes and the files.
//!
//! | file | what |
//! |---|---|
//! | [`law`] | the motion laws (translation, throw, spin, orbit, pendulum, travelling wave) |
//! | [`body`] | bodies as clouds of small Gaussians (box, sphere, sheet) |
//! | [`mod@catalogue`] | the scenes |
//! | [`build`] | a scene's Gaussians at any time, and its ground truth |
//! | [`rig`] | monocular and multi-view cameras |
//! | [`mod@write`] | rendering and the files |
//! | [`ground_truth`] | `motion.json` |
//! | [`trajectory`] | the trajectory error of a trained model against the ground truth |

pub mod body;
pub mod build;
pub mod catalogue;
pub mod ground_truth;
pub mod law;
pub mod rig;
pub mod trajectory;
pub mod write;

pub use build::{BuiltScene, Spacing};
pub use catalogue::{SceneSpec, catalogue, select};
pub use ground_truth::GroundTruth;
pub use law::Law;
pub use trajectory::{TrajectoryError, model_trajectory_error, trajectory_error};
pub use write::{Layout, Variant, write_scene};
