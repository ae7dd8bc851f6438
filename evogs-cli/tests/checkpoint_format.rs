//! Checkpoints are plain safetensors files: written by a training run here, read back with the
//! `safetensors` crate alone (not evogs' reader), with the names, dtypes, shapes, values and
//! metadata the trainer holds. Runs of the first format (`checkpoint.bin`) still load,
//! resume bit for bit, and are replaced by `checkpoint.safetensors` at their next save.

use evogs::config::TrainConfig;
use evogs::data::{Dataset, LoadOptions};
use evogs::field::HexPlaneConfig;
use evogs::run::archive::METADATA_KEY;
use evogs::run::checkpoint;
use evogs::train::step::ViewData;
use evogs::train::trainer::Trainer;
use evogs::train::views::training_views;
use evogs_cli::app::Silent;
use evogs_cli::app::paths::{RunFolder, shipped_scene};
use evogs_cli::app::train::{TrainArgs, train};
use safetensors::{Dtype, SafeTensors};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::Path;

mod common;

fn tiny_config() -> TrainConfig {
    let mut c = TrainConfig::fast();
    c.data.downscale = 8;
    c.field.hexplane = HexPlaneConfig {
        channels: 2,
        resolution: [4, 4, 4, 4],
        multires: vec![1],
    };
    c.field.width = 8;
    c.schedule.warmup_iters = 6;
    c.schedule.iterations = 16;
    c.schedule.curriculum_iters = 0;
    c.densify.from_iter = 4;
    c.densify.until_iter = 12;
    c.densify.interval = 4;
    c.densify.opacity_reset_interval = 0;
    c.loss.coherence_samples = 16;
    // The coherence loss, off in `fast`, on so the test covers it.
    c.loss.lambda_coherence = 0.01;
    c
}

/// A trainer for `c` on the shipped scene, and its views.
fn trainer(c: &TrainConfig) -> (Trainer, Vec<ViewData<f32>>) {
    let ds = Dataset::load(
        &shipped_scene(),
        &LoadOptions {
            downscale: c.data.downscale,
            ..LoadOptions::default()
        },
    )
    .expect("scene");
    let views = training_views(&ds.train, &(0..ds.train.len()).collect::<Vec<_>>()).expect("views");
    let pts = ds.points.expect("points");
    let pos: Vec<[f32; 3]> = pts.positions.iter().step_by(4).copied().collect();
    let t = Trainer::new(c.clone(), views.clone(), Some((&pos, None))).expect("trainer");
    (t, views)
}

fn le_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}
fn le_u64(v: &[u64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Every array a checkpoint of `t` must hold, as safetensors would: name → (dtype, bytes).
fn expected(t: &Trainer) -> BTreeMap<String, (Dtype, Vec<u8>)> {
    let mut e = BTreeMap::new();
    let mut f = |name: &str, v: Vec<f32>| {
        e.insert(name.to_string(), (Dtype::F32, le_f32(&v)));
    };
    let m = &t.model();
    let c = &m.canonical;
    f(
        "canonical.means",
        c.means.iter().flat_map(|v| v.to_array()).collect(),
    );
    f(
        "canonical.log_scales",
        c.log_scales.iter().flat_map(|v| v.to_array()).collect(),
    );
    f(
        "canonical.quats",
        c.quats.iter().flat_map(|q| q.to_array()).collect(),
    );
    f("canonical.opacity_logits", c.opacity_logits.clone());
    f("canonical.sh", c.sh.iter().flatten().copied().collect());
    for (k, a) in m.anchors.iter().enumerate() {
        f(
            &format!("anchor{k}.means"),
            a.means.iter().flat_map(|v| v.to_array()).collect(),
        );
        f(
            &format!("anchor{k}.log_scales"),
            a.log_scales.iter().flat_map(|v| v.to_array()).collect(),
        );
        f(
            &format!("anchor{k}.quats"),
            a.quats.iter().flat_map(|q| q.to_array()).collect(),
        );
    }
    f("field", m.field.params().to_vec());
    let o = &t.optimizer();
    let mut groups = vec![
        ("canonical.means", &o.canonical.means),
        ("canonical.log_scales", &o.canonical.log_scales),
        ("canonical.quats", &o.canonical.quats),
        ("opacity", &o.opacity),
        ("sh_dc", &o.sh_dc),
        ("sh_rest", &o.sh_rest),
    ];
    let anchor_names: Vec<[String; 3]> = (0..o.anchors.len())
        .map(|k| {
            [
                format!("anchor{k}.means"),
                format!("anchor{k}.log_scales"),
                format!("anchor{k}.quats"),
            ]
        })
        .collect();
    for (names, g) in anchor_names.iter().zip(&o.anchors) {
        groups.push((&names[0], &g.means));
        groups.push((&names[1], &g.log_scales));
        groups.push((&names[2], &g.quats));
    }
    groups.push(("grid", &o.grid));
    groups.push(("mlp", &o.mlp));
    for (name, s) in &groups {
        f(&format!("adam.{name}.m"), s.m.clone());
        f(&format!("adam.{name}.v"), s.v.clone());
    }
    f("stats.accum", t.densify_stats().accum.clone());
    let steps: Vec<u64> = groups.iter().map(|(_, s)| s.step).collect();
    e.insert("adam.steps".into(), (Dtype::U64, le_u64(&steps)));
    let widen = |v: &[u32]| v.iter().map(|&x| u64::from(x)).collect::<Vec<_>>();
    e.insert(
        "stats.count".into(),
        (Dtype::U64, le_u64(&widen(&t.densify_stats().count))),
    );
    e.insert(
        "stats.max_radius".into(),
        (Dtype::U64, le_u64(&widen(&t.densify_stats().max_radius))),
    );
    let order: Vec<u64> = t.view_order().iter().map(|&v| v as u64).collect();
    e.insert("order".into(), (Dtype::U64, le_u64(&order)));
    e
}

/// The `evogs` metadata entry of a safetensors file.
fn metadata_entry(bytes: &[u8]) -> Value {
    let (_, header) = SafeTensors::read_metadata(bytes).expect("header");
    let text = header
        .metadata()
        .as_ref()
        .and_then(|m| m.get(METADATA_KEY))
        .expect("the evogs metadata entry")
        .clone();
    serde_json::from_str(&text).expect("metadata JSON")
}

#[test]
fn a_checkpoint_is_a_plain_safetensors_file() {
    let (mut t, _) = trainer(&tiny_config());
    for _ in 0..9 {
        t.step().expect("step");
    }
    assert!(t.model().dynamics_active, "past the warm-up");
    let dir = common::scratch("ckpt-st");
    let ck = dir.join("checkpoint.safetensors");
    checkpoint::save(&t, &ck).expect("save");
    let bytes = std::fs::read(&ck).expect("written");
    let st = SafeTensors::deserialize(&bytes).expect("a safetensors file");
    let want = expected(&t);
    let mut names = st.names();
    names.sort_unstable();
    assert_eq!(
        names,
        want.keys().map(String::as_str).collect::<Vec<_>>(),
        "tensor names"
    );
    for (name, (dtype, data)) in &want {
        let v = st.tensor(name).expect("tensor");
        let size = if *dtype == Dtype::U64 { 8 } else { 4 };
        assert_eq!(v.dtype(), *dtype, "{name}: dtype");
        assert_eq!(v.shape(), [data.len() / size], "{name}: one dimension");
        assert!(v.data() == data.as_slice(), "{name}: values bit for bit");
    }
    let entry = metadata_entry(&bytes);
    assert_eq!(entry["format"], "evogs archive", "archive format");
    let meta = &entry["meta"];
    assert_eq!(meta["format"], "evogs checkpoint", "checkpoint format");
    assert_eq!(meta["iteration"], json!(9), "iteration");
    assert_eq!(meta["gaussians"], json!(t.model().len()), "Gaussians");
    assert_eq!(
        meta["sh_degree"],
        json!(t.model().canonical.sh_degree),
        "SH"
    );
    assert_eq!(meta["config"], json!(t.cfg().to_toml()), "configuration");
    assert_eq!(
        meta["rng_state"],
        json!(t.rng_state().to_string()),
        "random state"
    );
    assert_eq!(
        meta["log"].as_array().map(Vec::len),
        Some(t.log().len()),
        "log rows"
    );
    assert!(
        entry["meta_f64_bits"]
            .as_array()
            .is_some_and(|b| b.iter().any(|x| x.as_u64() == Some(t.extent().to_bits()))),
        "the float bits hold the extent exactly"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// Converts a safetensors checkpoint into the first format (`EVOGSCK1`), as the old writer
/// laid it out: magic, header length, JSON header, arrays in header order.
fn to_first_format(st_bytes: &[u8]) -> Vec<u8> {
    let st = SafeTensors::deserialize(st_bytes).expect("safetensors");
    let entry = metadata_entry(st_bytes);
    let mut names = st.names();
    names.sort_unstable();
    let mut arrays = Vec::new();
    let mut data = Vec::new();
    for name in names {
        let v = st.tensor(name).expect("tensor");
        let kind = match v.dtype() {
            Dtype::F32 => "f32",
            Dtype::U64 => "u64",
            other => panic!("unexpected dtype {other:?}"),
        };
        arrays.push(json!({"name": name, "kind": kind, "len": v.shape()[0]}));
        data.extend_from_slice(v.data());
    }
    let header = json!({
        "meta": entry["meta"],
        "arrays": arrays,
        "meta_f64_bits": entry["meta_f64_bits"],
    })
    .to_string();
    let mut out = b"EVOGSCK1".to_vec();
    out.extend_from_slice(&(header.len() as u64).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(&data);
    out
}

#[test]
fn a_first_format_checkpoint_resumes_bit_for_bit() {
    let c = tiny_config();
    let (mut a, views) = trainer(&c);
    let dir = common::scratch("ckpt-legacy");
    let st = dir.join("new.safetensors");
    let old = dir.join("checkpoint.bin");
    while !a.finished() {
        a.step().expect("step");
        if a.iteration() == 9 {
            checkpoint::save(&a, &st).expect("save");
            let bytes = std::fs::read(&st).expect("read");
            std::fs::write(&old, to_first_format(&bytes)).expect("write the old format");
        }
    }
    let mut b = checkpoint::resume(&old, views).expect("resume from checkpoint.bin");
    assert_eq!(b.iteration(), 9, "resumed iteration");
    while !b.finished() {
        b.step().expect("step");
    }
    assert_eq!(
        a.model().canonical,
        b.model().canonical,
        "canonical identical"
    );
    assert_eq!(a.model().anchors, b.model().anchors, "anchors identical");
    assert!(
        a.model().field.params() == b.model().field.params(),
        "field identical"
    );
    assert_eq!(a.optimizer(), b.optimizer(), "optimiser identical");
    std::fs::remove_dir_all(dir).ok();
}

/// Export of an older run reads its `checkpoint.bin`; resuming it writes
/// `checkpoint.safetensors` and removes the superseded file.
#[test]
fn an_older_run_folder_is_read_and_converted() {
    let dir = common::scratch("ckpt-folder");
    let run = common::tiny_run(&dir);
    let folder = RunFolder::new(&run);
    let new = folder.checkpoint_to_write();
    let old = folder.legacy_checkpoint();
    assert_eq!(folder.checkpoint(), new, "a new run's checkpoint");
    let bytes = std::fs::read(&new).expect("checkpoint");
    std::fs::write(&old, to_first_format(&bytes)).expect("old format");
    std::fs::remove_file(&new).expect("remove");
    assert_eq!(folder.checkpoint(), old, "only the old file: it is read");
    let ply = dir.join("x.ply");
    let n = evogs_cli::app::export::export(&run, 0.5, &ply).expect("export an older run");
    assert!(n > 0 && ply.is_file(), "exported {n} Gaussians");
    let before = model(&old);
    train(
        &TrainArgs {
            data: Some(shipped_scene()),
            out: run.clone(),
            resume: true,
            skip_outputs: true,
            ..TrainArgs::default()
        },
        &mut Silent,
    )
    .expect("resume an older run");
    assert!(new.is_file() && !old.exists(), "converted");
    assert_eq!(model(&new), before, "the same model");
    std::fs::remove_dir_all(dir).ok();
}

fn model(p: &Path) -> String {
    let l = checkpoint::load_model(p).expect("load");
    format!(
        "{:?} {:?} {:?}",
        l.model.canonical,
        l.model.anchors,
        l.model.field.params()
    )
}
