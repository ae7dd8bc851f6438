//! Checkpoints: everything a run needs to continue bit for bit (model, Adam moments,
//! densification accumulators, random state, view order, log), in one [`Archive`] written
//! atomically.

use super::archive::{Archive, ArchiveError};
use crate::config::TrainConfig;
use crate::field::{NeuralField, TimeMapping};
use crate::model::{AnchorState, Model};
use crate::train::adam::AdamState;
use crate::train::densify::DensifyStats;
use crate::train::frames::TrainViews;
use crate::train::optim::{Optimizer, StateGroups};
use crate::train::trainer::{LogRow, Trainer};
use evogs_math::rng::SplitMix64;
use evogs_math::{Quat, Vec3};
use evogs_splat::Splats;
use serde_json::json;
use std::path::Path;

/// Checkpoint format version.
///
/// Still 1 after the motion searches were removed: checkpoints written while they existed may
/// also hold an `orbit_bodies` array (the bodies the orbit search had moved, read only by the
/// spin search), which is ignored, and their stored configuration's `[spin_search]` and
/// `[orbit_search]` tables are dropped by [`TrainConfig::from_run_toml`]. Every other array and
/// field is as before, so such checkpoints load, evaluate, render, export and resume as
/// before (without any search still pending in them), and older builds read the new ones.
const VERSION: u64 = 1;

/// Why a checkpoint could not be used.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// Reading or writing failed.
    #[error(transparent)]
    Archive(#[from] ArchiveError),
    /// The file is an archive but not a usable checkpoint.
    #[error("{path}: {msg}")]
    Invalid {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
}

fn flat_vec3(v: &[Vec3<f32>]) -> Vec<f32> {
    v.iter().flat_map(|x| x.to_array()).collect()
}
fn flat_quat(v: &[Quat<f32>]) -> Vec<f32> {
    v.iter().flat_map(|q| q.to_array()).collect()
}
fn put_adam(ar: &mut Archive, name: &str, s: &AdamState, steps: &mut Vec<u64>) {
    ar.put_f32(&format!("adam.{name}.m"), &s.m);
    ar.put_f32(&format!("adam.{name}.v"), &s.v);
    steps.push(s.step);
}
fn put_groups(ar: &mut Archive, name: &str, g: &StateGroups, steps: &mut Vec<u64>) {
    put_adam(ar, &format!("{name}.means"), &g.means, steps);
    put_adam(ar, &format!("{name}.log_scales"), &g.log_scales, steps);
    put_adam(ar, &format!("{name}.quats"), &g.quats, steps);
}

/// Writes a trainer's complete state.
///
/// # Errors
/// I/O failures (the previous checkpoint, if any, is left intact).
pub fn save(t: &Trainer, path: &Path) -> Result<(), CheckpointError> {
    let m = &t.model;
    let (lo, hi) = m.field.hexplane().aabb();
    let time = m.field.hexplane().time_mapping();
    let meta = json!({
        "format": "evogs checkpoint",
        "version": VERSION,
        "iteration": t.iteration,
        "train_seconds": t.train_seconds,
        "extent": t.extent,
        "time_range": [t.time_range.0, t.time_range.1],
        "dynamics_active": m.dynamics_active,
        "anchor_times": m.anchor_times,
        "sh_degree": m.canonical.sh_degree,
        "gaussians": m.len(),
        "aabb": [lo, hi],
        "time_mapping": serde_json::to_value(time).unwrap_or_default(),
        "max_step": m.max_step,
        "order_pos": t.order_pos,
        "rng_state": t.rng.state().to_string(),
        "config": t.cfg.to_toml(),
        "log": t.log,
    });
    let mut ar = Archive::new(meta);
    let c = &m.canonical;
    ar.put_f32("canonical.means", &flat_vec3(&c.means));
    ar.put_f32("canonical.log_scales", &flat_vec3(&c.log_scales));
    ar.put_f32("canonical.quats", &flat_quat(&c.quats));
    ar.put_f32("canonical.opacity_logits", &c.opacity_logits);
    ar.put_f32(
        "canonical.sh",
        &c.sh.iter().flatten().copied().collect::<Vec<_>>(),
    );
    for (k, a) in m.anchors.iter().enumerate() {
        ar.put_f32(&format!("anchor{k}.means"), &flat_vec3(&a.means));
        ar.put_f32(&format!("anchor{k}.log_scales"), &flat_vec3(&a.log_scales));
        ar.put_f32(&format!("anchor{k}.quats"), &flat_quat(&a.quats));
    }
    ar.put_f32("field", m.field.params());
    let o = &t.optim;
    let mut steps = Vec::new();
    put_groups(&mut ar, "canonical", &o.canonical, &mut steps);
    put_adam(&mut ar, "opacity", &o.opacity, &mut steps);
    put_adam(&mut ar, "sh_dc", &o.sh_dc, &mut steps);
    put_adam(&mut ar, "sh_rest", &o.sh_rest, &mut steps);
    for (k, g) in o.anchors.iter().enumerate() {
        put_groups(&mut ar, &format!("anchor{k}"), g, &mut steps);
    }
    put_adam(&mut ar, "grid", &o.grid, &mut steps);
    put_adam(&mut ar, "mlp", &o.mlp, &mut steps);
    ar.put_u64("adam.steps", &steps);
    ar.put_f32("stats.accum", &t.stats.accum);
    ar.put_u64(
        "stats.count",
        &t.stats
            .count
            .iter()
            .map(|&v| u64::from(v))
            .collect::<Vec<_>>(),
    );
    ar.put_u64(
        "stats.max_radius",
        &t.stats
            .max_radius
            .iter()
            .map(|&v| u64::from(v))
            .collect::<Vec<_>>(),
    );
    ar.put_u64(
        "order",
        &t.order.iter().map(|&v| v as u64).collect::<Vec<_>>(),
    );
    if let Some((name, i)) = ar.first_non_finite() {
        return Err(CheckpointError::Invalid {
            path: path.display().to_string(),
            msg: format!(
                "not written: `{name}`[{i}] is not finite at iteration {} (the previous \
                 checkpoint is kept)",
                t.iteration
            ),
        });
    }
    ar.write(path)?;
    Ok(())
}

/// A model read back from a checkpoint, with its configuration and metadata.
#[derive(Debug)]
pub struct Loaded {
    /// The run's configuration.
    pub cfg: TrainConfig,
    /// The model.
    pub model: Model<f32>,
    /// The raw archive (metadata and the optimiser arrays).
    pub archive: Archive,
}

/// Reads the model of a checkpoint (enough for evaluation, rendering and export).
///
/// # Errors
/// Unreadable, corrupt or inconsistent files.
pub fn load_model(path: &Path) -> Result<Loaded, CheckpointError> {
    let ar = Archive::read(path)?;
    let p = path.display().to_string();
    let bad = |msg: String| CheckpointError::Invalid {
        path: p.clone(),
        msg,
    };
    if let Some((name, i)) = ar.first_non_finite() {
        return Err(bad(format!(
            "`{name}`[{i}] is not finite: the checkpoint is corrupt"
        )));
    }
    let meta = &ar.meta;
    if meta["format"] != "evogs checkpoint" || meta["version"].as_u64() != Some(VERSION) {
        return Err(bad("not an evogs checkpoint of version 1".into()));
    }
    let cfg = TrainConfig::from_run_toml(meta["config"].as_str().unwrap_or_default())
        .map_err(|e| bad(format!("stored configuration: {e}")))?;
    let f = |name: &str| {
        ar.f32(name)
            .ok_or_else(|| bad(format!("missing array `{name}`")))
    };
    let v3 = |d: &[f32]| -> Vec<Vec3<f32>> { d.chunks_exact(3).map(Vec3::from_slice).collect() };
    let qs = |d: &[f32]| -> Vec<Quat<f32>> { d.chunks_exact(4).map(Quat::from_slice).collect() };
    let sh_degree = usize::try_from(meta["sh_degree"].as_u64().unwrap_or(0)).unwrap_or(0);
    let canonical = Splats {
        sh_degree,
        means: v3(f("canonical.means")?),
        log_scales: v3(f("canonical.log_scales")?),
        quats: qs(f("canonical.quats")?),
        opacity_logits: f("canonical.opacity_logits")?.to_vec(),
        sh: f("canonical.sh")?
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    };
    if !canonical.check() {
        return Err(bad("canonical Gaussians have inconsistent lengths".into()));
    }
    let arr3 = |v: &serde_json::Value| -> Option<[f64; 3]> {
        Some([v[0].as_f64()?, v[1].as_f64()?, v[2].as_f64()?])
    };
    let lo = arr3(&meta["aabb"][0]).ok_or_else(|| bad("missing aabb".into()))?;
    let hi = arr3(&meta["aabb"][1]).ok_or_else(|| bad("missing aabb".into()))?;
    let time: TimeMapping = serde_json::from_value(meta["time_mapping"].clone())
        .map_err(|e| bad(format!("time mapping: {e}")))?;
    let mut field = NeuralField::new(&cfg.field, lo, hi, time, 0);
    let params = f("field")?;
    if params.len() != field.params().len() {
        return Err(bad(format!(
            "field has {} parameters, the configuration needs {}",
            params.len(),
            field.params().len()
        )));
    }
    field.params_mut().copy_from_slice(params);
    let anchor_times: Vec<f64> = meta["anchor_times"]
        .as_array()
        .map(|a| a.iter().filter_map(serde_json::Value::as_f64).collect())
        .unwrap_or_default();
    let method = cfg.dynamics.method;
    let max_step = meta["max_step"]
        .as_f64()
        .ok_or_else(|| bad("missing max_step".into()))?;
    let mut model = Model::new(
        canonical,
        field,
        cfg.dynamics.motion,
        cfg.dynamics.waypoints,
        method,
        max_step,
        anchor_times,
    );
    for k in 0..model.anchors.len() {
        model.anchors[k] = AnchorState {
            means: v3(f(&format!("anchor{k}.means"))?),
            log_scales: v3(f(&format!("anchor{k}.log_scales"))?),
            quats: qs(f(&format!("anchor{k}.quats"))?),
        };
        if model.anchors[k].means.len() != model.len() {
            return Err(bad(format!(
                "anchor {k} has a different number of Gaussians"
            )));
        }
    }
    model.dynamics_active = meta["dynamics_active"].as_bool().unwrap_or(false);
    Ok(Loaded {
        cfg,
        model,
        archive: ar,
    })
}

fn get_adam(ar: &Archive, name: &str, steps: &mut std::slice::Iter<'_, u64>) -> Option<AdamState> {
    Some(AdamState {
        m: ar.f32(&format!("adam.{name}.m"))?.to_vec(),
        v: ar.f32(&format!("adam.{name}.v"))?.to_vec(),
        step: *steps.next()?,
    })
}
fn get_groups(
    ar: &Archive,
    name: &str,
    steps: &mut std::slice::Iter<'_, u64>,
) -> Option<StateGroups> {
    Some(StateGroups {
        means: get_adam(ar, &format!("{name}.means"), steps)?,
        log_scales: get_adam(ar, &format!("{name}.log_scales"), steps)?,
        quats: get_adam(ar, &format!("{name}.quats"), steps)?,
    })
}

/// Rebuilds a trainer from a checkpoint and the (same) training views, to continue exactly
/// where it stopped.
///
/// # Errors
/// Unreadable or inconsistent checkpoints.
pub fn resume(path: &Path, views: impl Into<TrainViews>) -> Result<Trainer, CheckpointError> {
    let Loaded {
        cfg,
        model,
        archive: ar,
    } = load_model(path)?;
    let p = path.display().to_string();
    let bad = |msg: &str| CheckpointError::Invalid {
        path: p.clone(),
        msg: msg.to_string(),
    };
    let meta = ar.meta.clone();
    let mut t = Trainer::new(cfg, views, None).map_err(|e| bad(&e.to_string()))?;
    t.model = model;
    let all_steps = ar
        .u64("adam.steps")
        .ok_or_else(|| bad("missing Adam steps"))?
        .to_vec();
    let mut steps = all_steps.iter();
    let mut o = crate::train::optim::Optimizer {
        adam: t.optim.adam,
        ..Optimizer::default()
    };
    o.canonical = get_groups(&ar, "canonical", &mut steps)
        .ok_or_else(|| bad("missing canonical Adam state"))?;
    o.opacity =
        get_adam(&ar, "opacity", &mut steps).ok_or_else(|| bad("missing opacity Adam state"))?;
    o.sh_dc = get_adam(&ar, "sh_dc", &mut steps).ok_or_else(|| bad("missing SH Adam state"))?;
    o.sh_rest = get_adam(&ar, "sh_rest", &mut steps).ok_or_else(|| bad("missing SH Adam state"))?;
    for k in 0..t.model.anchors.len() {
        o.anchors.push(
            get_groups(&ar, &format!("anchor{k}"), &mut steps)
                .ok_or_else(|| bad("missing anchor Adam state"))?,
        );
    }
    o.grid = get_adam(&ar, "grid", &mut steps).ok_or_else(|| bad("missing grid Adam state"))?;
    o.mlp = get_adam(&ar, "mlp", &mut steps).ok_or_else(|| bad("missing MLP Adam state"))?;
    t.optim = o;
    t.iteration = meta["iteration"]
        .as_u64()
        .ok_or_else(|| bad("missing iteration"))?;
    t.train_seconds = meta["train_seconds"].as_f64().unwrap_or(0.0);
    t.extent = meta["extent"]
        .as_f64()
        .ok_or_else(|| bad("missing extent"))?;
    t.time_range = (
        meta["time_range"][0].as_f64().unwrap_or(0.0),
        meta["time_range"][1].as_f64().unwrap_or(1.0),
    );
    t.rng = SplitMix64::new(
        meta["rng_state"]
            .as_str()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad("missing rng state"))?,
    );
    t.order = ar
        .u64("order")
        .unwrap_or_default()
        .iter()
        .map(|&v| usize::try_from(v).unwrap_or(0))
        .collect();
    t.order_pos = usize::try_from(meta["order_pos"].as_u64().unwrap_or(0)).unwrap_or(0);
    t.log = serde_json::from_value::<Vec<LogRow>>(meta["log"].clone()).unwrap_or_default();
    t.stats = DensifyStats {
        accum: ar.f32("stats.accum").unwrap_or_default().to_vec(),
        count: ar
            .u64("stats.count")
            .unwrap_or_default()
            .iter()
            .map(|&v| u32::try_from(v).unwrap_or(u32::MAX))
            .collect(),
        max_radius: ar
            .u64("stats.max_radius")
            .unwrap_or_default()
            .iter()
            .map(|&v| u32::try_from(v).unwrap_or(u32::MAX))
            .collect(),
    };
    if t.stats.accum.len() != t.model.len() {
        return Err(bad("densification statistics have the wrong length"));
    }
    t.model.field.set_par(t.par);
    Ok(t)
}
