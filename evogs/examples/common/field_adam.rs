//! Adam on the neural field's two parameter groups (HexPlane grids and MLP), as training steps
//! them, for the diagnostic examples that fit the field alone.

use evogs::field::NeuralField;
use evogs::train::adam::{Adam, AdamState};
use evogs_math::Par;

/// The field's two Adam groups and their base rates.
pub(crate) struct FieldAdam {
    grid: AdamState,
    mlp: AdamState,
    adam: Adam,
    grid_lr: f64,
    mlp_lr: f64,
}

impl FieldAdam {
    /// Fresh Adam states for `field`, with base rates for the grids and the MLP.
    pub(crate) fn new(field: &NeuralField<f32>, grid_lr: f64, mlp_lr: f64) -> Self {
        Self {
            grid: AdamState::new(field.grid_range().len()),
            mlp: AdamState::new(field.mlp_range().len()),
            adam: Adam::default(),
            grid_lr,
            mlp_lr,
        }
    }

    /// One step with the gradient `g` of every field parameter, at the base rates × `scale`.
    pub(crate) fn step(&mut self, field: &mut NeuralField<f32>, g: &[f32], scale: f64) {
        let (gr, mr) = (field.grid_range(), field.mlp_range());
        let p = field.params_mut();
        self.grid.step(
            &self.adam,
            self.grid_lr * scale,
            Par::Seq,
            &mut p[gr.clone()],
            &g[gr],
        );
        self.mlp.step(
            &self.adam,
            self.mlp_lr * scale,
            Par::Seq,
            &mut p[mr.clone()],
            &g[mr],
        );
    }
}
