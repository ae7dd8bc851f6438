//! Checkpoints are plain safetensors files: written by a training run here, read back with the
//! `safetensors` crate alone (not evogs' reader), with the names, dtypes, shapes, values and
//! metadata the trainer holds; a checkpoint whose metadata misses a field or has a wrong one
//! is refused with a message naming the file and the field.

use evogs::config::TrainConfig;
use evogs::data::{Dataset, LoadOptions};
use evogs::field::HexPlaneConfig;
use evogs::run::archive::METADATA_KEY;
use evogs::run::checkpoint;
use evogs::train::step::ViewData;
use evogs::train::trainer::Trainer;
use evogs::train::views::training_views;
use evogs_cli::app::paths::shipped_scene;
use safetensors::{Dtype, SafeTensors};
use serde_json::{Value, json};
use std::collections::BTreeMap;

use crate::common;

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
    let o = &t.state().optim;
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
    f("stats.accum", t.state().stats.accum.clone());
    let steps: Vec<u64> = groups.iter().map(|(_, s)| s.step).collect();
    e.insert("adam.steps".into(), (Dtype::U64, le_u64(&steps)));
    let widen = |v: &[u32]| v.iter().map(|&x| u64::from(x)).collect::<Vec<_>>();
    e.insert(
        "stats.count".into(),
        (Dtype::U64, le_u64(&widen(&t.state().stats.count))),
    );
    e.insert(
        "stats.max_radius".into(),
        (Dtype::U64, le_u64(&widen(&t.state().stats.max_radius))),
    );
    let order: Vec<u64> = t
        .state()
        .sampler
        .order()
        .iter()
        .map(|&v| v as u64)
        .collect();
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
        json!(t.state().rng.state().to_string()),
        "random state"
    );
    assert_eq!(
        meta["log"].as_array().map(Vec::len),
        Some(t.log().len()),
        "log rows"
    );
    assert!(
        meta["extent"]
            .as_f64()
            .is_some_and(|x| x.to_bits() == t.state().extent.to_bits()),
        "the extent exactly, as plain JSON"
    );
    assert!(entry.get("meta_f64_bits").is_none(), "no float bits");
    std::fs::remove_dir_all(dir).ok();
}

/// A checkpoint whose metadata lacks a field, or holds one of the wrong type, is refused
/// with a message that names the file and the field.
#[test]
fn a_missing_or_wrong_metadata_field_is_named() {
    let (mut t, views) = trainer(&tiny_config());
    t.step().expect("step");
    let dir = common::scratch("ckpt-meta");
    let ck = dir.join("checkpoint.safetensors");
    checkpoint::save(&t, &ck).expect("save");
    let good = evogs::run::archive::Archive::read(&ck).expect("archive");
    type Edit = fn(&mut Value);
    let edits: [(&str, Edit); 3] = [
        ("iteration", |m| {
            m.as_object_mut().expect("object").remove("iteration");
        }),
        ("extent", |m| m["extent"] = json!("far")),
        ("time_range", |m| m["time_range"] = json!([0.0])),
    ];
    for (field, edit) in edits {
        let mut ar = good.clone();
        edit(&mut ar.meta);
        ar.write(&ck).expect("write");
        let e = checkpoint::load_model(&ck)
            .expect_err("refused")
            .to_string();
        assert!(
            e.contains(&ck.display().to_string()) && e.contains(field),
            "the file and `{field}` named: {e}"
        );
    }
    good.write(&ck).expect("write");
    let back = checkpoint::resume(&ck, views).expect("the untouched checkpoint resumes");
    assert_eq!(back.iteration(), 1, "resumed");
    std::fs::remove_dir_all(dir).ok();
}
