//! Checkpoints: a model and the [`TrainerState`] of the run that trained it (Adam moments,
//! densification accumulators, random state, view order, log), everything a run needs to
//! continue bit for bit, in one [`Archive`] written atomically. The metadata is a typed
//! [`CheckpointMeta`]; the arrays are named after the model's parts and the optimiser's
//! parameter groups ([`Optimizer::groups`]). `docs/checkpoints.md` describes the format.

use super::archive::{Archive, ArchiveError};
use crate::config::TrainConfig;
use crate::data::DataIdentity;
use crate::field::TimeMapping;
use crate::model::{AnchorState, Model, ModelFrame, build_model};
use crate::train::adam::AdamState;
use crate::train::densify::DensifyStats;
use crate::train::frames::TrainViews;
use crate::train::optim::Optimizer;
use crate::train::sampler::ViewSampler;
use crate::train::state::TrainerState;
use crate::train::trainer::{LogRow, Trainer};
use evogs_math::rng::SplitMix64;
use evogs_math::{Quat, Vec3};
use evogs_splat::Splats;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Checkpoint format version. Checkpoints written before the metadata was typed (by the
/// same version) hold the same fields, and a `meta_f64_bits` entry that is no longer needed
/// (the JSON is read back exactly) and is ignored.
const VERSION: u64 = 1;

/// The `format` field of a checkpoint's metadata.
const FORMAT: &str = "evogs checkpoint";

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

/// A checkpoint's metadata (the arrays hold the rest).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointMeta {
    /// Always `evogs checkpoint`.
    pub format: String,
    /// Format version.
    pub version: u64,
    /// Iterations done.
    pub iteration: u64,
    /// Seconds spent in iterations.
    pub train_seconds: f64,
    /// Scene extent (learning-rate scale).
    pub extent: f64,
    /// Training time range.
    pub time_range: [f64; 2],
    /// Whether the dynamics are on.
    pub dynamics_active: bool,
    /// Anchor times.
    pub anchor_times: Vec<f64>,
    /// SH degree of the canonical Gaussians.
    pub sh_degree: usize,
    /// Number of Gaussians.
    pub gaussians: usize,
    /// The field's box (lower, upper corner).
    pub aabb: [[f64; 3]; 2],
    /// How the field reads time.
    pub time_mapping: TimeMapping,
    /// Largest ODE step.
    pub max_step: f64,
    /// Position in the view order.
    pub order_pos: usize,
    /// Random state, as decimal text (exact in every JSON reader).
    #[serde(with = "decimal")]
    pub rng_state: u64,
    /// The run's configuration (TOML).
    pub config: String,
    /// The log rows so far.
    pub log: Vec<LogRow>,
    /// The training data (absent in checkpoints written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<DataIdentity>,
}

/// A `u64` as decimal text.
mod decimal {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(super) fn serialize<S: Serializer>(v: &u64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&v.to_string())
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<u64, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

fn flat_vec3(v: &[Vec3<f32>]) -> Vec<f32> {
    v.iter().flat_map(|x| x.to_array()).collect()
}
fn flat_quat(v: &[Quat<f32>]) -> Vec<f32> {
    v.iter().flat_map(|q| q.to_array()).collect()
}
fn widen(v: &[u32]) -> Vec<u64> {
    v.iter().map(|&x| u64::from(x)).collect()
}

/// Writes a trainer's model and state.
///
/// # Errors
/// A non-finite value, or I/O failures (the previous checkpoint, if any, is left intact).
pub fn save(t: &Trainer, path: &Path) -> Result<(), CheckpointError> {
    let m = t.model();
    let st = t.state();
    let (lo, hi) = m.field.hexplane().aabb();
    let meta = CheckpointMeta {
        format: FORMAT.into(),
        version: VERSION,
        iteration: st.iteration,
        train_seconds: st.train_seconds,
        extent: st.extent,
        time_range: [st.time_range.0, st.time_range.1],
        dynamics_active: m.dynamics_active,
        anchor_times: m.anchor_times.clone(),
        sh_degree: m.canonical.sh_degree,
        gaussians: m.len(),
        aabb: [lo, hi],
        time_mapping: m.field.hexplane().time_mapping(),
        max_step: m.max_step,
        order_pos: st.sampler.pos(),
        rng_state: st.rng.state(),
        config: t.cfg().to_toml(),
        log: st.log.clone(),
        data: st.data.clone(),
    };
    let invalid = |msg: String| CheckpointError::Invalid {
        path: path.display().to_string(),
        msg,
    };
    let meta = serde_json::to_value(&meta).map_err(|e| invalid(format!("metadata: {e}")))?;
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
    if let Some(wf) = &m.waypoint_field {
        ar.put_f32("waypoint_field", wf.params());
    }
    let mut steps = Vec::new();
    let o = &st.optim;
    for g in o.groups() {
        let s = o.state(g);
        ar.put_f32(&format!("adam.{}.m", g.name()), &s.m);
        ar.put_f32(&format!("adam.{}.v", g.name()), &s.v);
        steps.push(s.step);
    }
    ar.put_u64("adam.steps", &steps);
    ar.put_f32("stats.accum", &st.stats.accum);
    ar.put_u64("stats.count", &widen(&st.stats.count));
    ar.put_u64("stats.max_radius", &widen(&st.stats.max_radius));
    ar.put_u64(
        "order",
        &st.sampler
            .order()
            .iter()
            .map(|&v| v as u64)
            .collect::<Vec<_>>(),
    );
    if let Some((name, i)) = ar.first_non_finite() {
        return Err(invalid(format!(
            "not written: `{name}`[{i}] is not finite at iteration {} (the previous \
             checkpoint is kept)",
            st.iteration
        )));
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
    /// The metadata.
    pub meta: CheckpointMeta,
    /// The raw archive (metadata and the optimiser arrays).
    pub archive: Archive,
}

/// Reads the typed metadata of an archive, naming the field that is missing or wrong.
fn read_meta(ar: &Archive) -> Result<CheckpointMeta, String> {
    if ar.meta.get("format").and_then(serde_json::Value::as_str) != Some(FORMAT) {
        return Err(format!(
            "not an evogs checkpoint (metadata `format` is not `{FORMAT}`)"
        ));
    }
    let meta: CheckpointMeta = serde_path_to_error::deserialize(&ar.meta).map_err(|e| {
        let field = e.path().to_string();
        let msg = e.inner().to_string();
        if field == "." {
            format!("metadata: {msg}")
        } else {
            format!("metadata field `{field}`: {msg}")
        }
    })?;
    if meta.version != VERSION {
        return Err(format!(
            "metadata field `version`: {} (this build reads version {VERSION})",
            meta.version
        ));
    }
    Ok(meta)
}

/// Reads the model of a checkpoint (enough for evaluation, rendering and export).
///
/// # Errors
/// Unreadable, corrupt or inconsistent files (the message names the file and, for the
/// metadata, the field).
pub fn load_model(path: &Path) -> Result<Loaded, CheckpointError> {
    let ar = Archive::read(path)?;
    let bad = |msg: String| CheckpointError::Invalid {
        path: path.display().to_string(),
        msg,
    };
    if let Some((name, i)) = ar.first_non_finite() {
        return Err(bad(format!(
            "`{name}`[{i}] is not finite: the checkpoint is corrupt"
        )));
    }
    let meta = read_meta(&ar).map_err(bad)?;
    let cfg = TrainConfig::from_run_toml(&meta.config)
        .map_err(|e| bad(format!("metadata field `config`: {e}")))?;
    let f = |name: &str| {
        ar.f32(name)
            .ok_or_else(|| bad(format!("missing array `{name}`")))
    };
    let v3 = |d: &[f32]| -> Vec<Vec3<f32>> { d.chunks_exact(3).map(Vec3::from_slice).collect() };
    let qs = |d: &[f32]| -> Vec<Quat<f32>> { d.chunks_exact(4).map(Quat::from_slice).collect() };
    let canonical = Splats {
        sh_degree: meta.sh_degree,
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
    if canonical.len() != meta.gaussians {
        return Err(bad(format!(
            "metadata field `gaussians`: {}, the arrays hold {}",
            meta.gaussians,
            canonical.len()
        )));
    }
    let frame = ModelFrame {
        aabb: (meta.aabb[0], meta.aabb[1]),
        time: meta.time_mapping,
        max_step: meta.max_step,
        anchor_times: meta.anchor_times.clone(),
        window: (meta.time_range[0], meta.time_range[1]),
    };
    let mut model = build_model(&cfg, canonical, frame);
    let params = f("field")?;
    if params.len() != model.field.params().len() {
        return Err(bad(format!(
            "field has {} parameters, the configuration needs {}",
            params.len(),
            model.field.params().len()
        )));
    }
    model.field.params_mut().copy_from_slice(params);
    if let Some(wf) = model.waypoint_field.as_mut() {
        let params = f("waypoint_field")?;
        if params.len() != wf.params().len() {
            return Err(bad(format!(
                "waypoint_field has {} parameters, the configuration needs {}",
                params.len(),
                wf.params().len()
            )));
        }
        wf.params_mut().copy_from_slice(params);
    }
    for k in 0..model.anchors.len() {
        model.anchors[k] = AnchorState {
            means: v3(f(&format!("anchor{k}.means"))?),
            log_scales: v3(f(&format!("anchor{k}.log_scales"))?),
            quats: qs(f(&format!("anchor{k}.quats"))?),
        };
        let a = &model.anchors[k];
        if a.means.len() != model.len()
            || a.log_scales.len() != model.len()
            || a.quats.len() != model.len()
        {
            return Err(bad(format!(
                "anchor {k} has a different number of Gaussians"
            )));
        }
    }
    model.dynamics_active = meta.dynamics_active;
    Ok(Loaded {
        cfg,
        model,
        meta,
        archive: ar,
    })
}

/// Reads the trainer state of a checkpoint for `model` (read by [`load_model`]).
///
/// # Errors
/// A missing or inconsistent array, in words.
fn read_state(
    ar: &Archive,
    meta: &CheckpointMeta,
    model: &Model<f32>,
) -> Result<TrainerState, String> {
    let f = |name: &str| {
        ar.f32(name)
            .ok_or_else(|| format!("missing array `{name}`"))
    };
    let u = |name: &str| {
        ar.u64(name)
            .ok_or_else(|| format!("missing array `{name}`"))
    };
    let narrow = |v: &[u64]| -> Vec<u32> {
        v.iter()
            .map(|&x| u32::try_from(x).unwrap_or(u32::MAX))
            .collect()
    };
    let mut optim = Optimizer::new(model);
    let steps = u("adam.steps")?;
    let groups: Vec<_> = optim.groups().collect();
    if steps.len() != groups.len() {
        return Err(format!(
            "`adam.steps` has {} entries for {} parameter groups",
            steps.len(),
            groups.len()
        ));
    }
    for (g, &step) in groups.into_iter().zip(steps) {
        let name = g.name();
        *optim.state_mut(g) = AdamState {
            m: f(&format!("adam.{name}.m"))?.to_vec(),
            v: f(&format!("adam.{name}.v"))?.to_vec(),
            step,
        };
    }
    let order = u("order")?
        .iter()
        .map(|&v| usize::try_from(v).map_err(|_| "view order entry out of range".to_string()))
        .collect::<Result<Vec<_>, _>>()?;
    let sampler = ViewSampler::from_parts(order, meta.order_pos)?;
    let state = TrainerState {
        iteration: meta.iteration,
        train_seconds: meta.train_seconds,
        extent: meta.extent,
        time_range: (meta.time_range[0], meta.time_range[1]),
        rng: SplitMix64::new(meta.rng_state),
        sampler,
        log: meta.log.clone(),
        stats: DensifyStats {
            accum: f("stats.accum")?.to_vec(),
            count: narrow(u("stats.count")?),
            max_radius: narrow(u("stats.max_radius")?),
        },
        optim,
        data: meta.data.clone(),
    };
    state.check(model)?;
    Ok(state)
}

/// Rebuilds a trainer from a checkpoint (its model and its state) and the same training
/// views, to continue exactly where it stopped.
///
/// # Errors
/// Unreadable or inconsistent checkpoints.
pub fn resume(path: &Path, views: impl Into<TrainViews>) -> Result<Trainer, CheckpointError> {
    resume_from(load_model(path)?, path, views)
}

/// [`resume`] from a checkpoint already read (from `path`, which errors name): a caller
/// that compared its configuration and data with what it was asked for first reads it once.
///
/// # Errors
/// An inconsistent checkpoint.
pub fn resume_from(
    loaded: Loaded,
    path: &Path,
    views: impl Into<TrainViews>,
) -> Result<Trainer, CheckpointError> {
    let Loaded {
        cfg,
        model,
        meta,
        archive,
    } = loaded;
    let bad = |msg: String| CheckpointError::Invalid {
        path: path.display().to_string(),
        msg,
    };
    let state = read_state(&archive, &meta, &model).map_err(bad)?;
    Trainer::from_parts(cfg, model, state, views).map_err(|e| bad(e.to_string()))
}
