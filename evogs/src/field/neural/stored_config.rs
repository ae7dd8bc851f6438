//! How a [`NeuralFieldConfig`] is read from a file: the current keys, and the removed
//! `twist` key, which is accepted as `false` only (old run configurations say
//! `twist = false`).

use super::NeuralFieldConfig;
use crate::field::HexPlaneConfig;

/// The keys of `[field]` in a configuration file.
#[derive(serde::Deserialize)]
pub(super) struct StoredFieldConfig {
    hexplane: HexPlaneConfig,
    width: usize,
    output_scales: [f64; 3],
    #[serde(default)]
    zero_init_output: bool,
    /// The removed twist velocity: only `false` (its old default) is accepted.
    #[serde(default)]
    twist: bool,
}

impl TryFrom<StoredFieldConfig> for NeuralFieldConfig {
    type Error = &'static str;

    fn try_from(s: StoredFieldConfig) -> Result<Self, Self::Error> {
        if s.twist {
            return Err(
                "`field.twist = true`: the twist velocity was removed (it measured \
                        worse, docs/results.md); drop the key or set it to false",
            );
        }
        Ok(Self {
            hexplane: s.hexplane,
            width: s.width,
            output_scales: s.output_scales,
            zero_init_output: s.zero_init_output,
        })
    }
}
