//! Dataset loading: the shipped scene loads, and every kind of bad input gives a one-line
//! error naming the file and the problem (never a panic).

use evogs::data::{Dataset, LoadOptions};
use evogs::train::views::training_views;
use evogs_cli::app::paths::shipped_scene;
use std::path::{Path, PathBuf};

/// A copy of the shipped scene's JSON files and the first few frames, in a fresh folder.
fn scene_copy(tag: &str) -> PathBuf {
    let src = shipped_scene();
    let dst = std::env::temp_dir().join(format!("evogs-ds-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dst);
    std::fs::create_dir_all(dst.join("train")).expect("tmp");
    // Keep three training frames.
    let text = std::fs::read_to_string(src.join("transforms_train.json")).expect("train json");
    let mut v: serde_json::Value = serde_json::from_str(&text).expect("json");
    let frames = v["frames"].as_array_mut().expect("frames");
    frames.truncate(3);
    for f in frames.iter() {
        let rel = f["file_path"].as_str().expect("path").to_string() + ".png";
        std::fs::copy(src.join(&rel), dst.join(&rel)).expect("copy frame");
    }
    std::fs::write(
        dst.join("transforms_train.json"),
        serde_json::to_string(&v).expect("json"),
    )
    .expect("write");
    dst
}

fn load(dir: &Path) -> Result<Dataset, String> {
    Dataset::load(dir, &LoadOptions::default()).map_err(|e| e.to_string())
}

fn edit_json(dir: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let p = dir.join("transforms_train.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&p).expect("read")).expect("json");
    f(&mut v);
    std::fs::write(p, serde_json::to_string(&v).expect("json")).expect("write");
}

#[test]
fn shipped_scene_loads_with_all_splits_and_points() {
    let ds = load(&shipped_scene()).expect("shipped scene loads");
    assert_eq!(
        (ds.train.len(), ds.val.len(), ds.test.len()),
        (75, 10, 10),
        "split sizes"
    );
    let img = ds.train[0].image.as_ref().expect("image");
    assert_eq!((img.width(), img.height()), (200, 200), "image size");
    assert!(
        img.data().iter().all(|v| (0.0..=1.0).contains(v)),
        "composited values in [0, 1]"
    );
    assert_eq!(
        ds.points.as_ref().map(|p| p.positions.len()),
        Some(5000),
        "point cloud"
    );
    let (t0, t1) = ds.train_time_range();
    assert!(t0 >= 0.0 && t1 <= 1.0 && t1 > t0, "times in [0, 1]");
    let half = Dataset::load(
        &shipped_scene(),
        &LoadOptions {
            downscale: 2,
            ..LoadOptions::default()
        },
    )
    .expect("downscaled");
    assert_eq!(half.train[0].width, 100, "downscale by 2");
    assert!(training_views(&ds.train, &[0, 1]).is_ok(), "cameras build");
}

#[test]
fn bad_inputs_name_the_file_and_the_problem() {
    let missing = std::env::temp_dir().join("evogs-no-such-dataset");
    let e = load(&missing).expect_err("missing folder");
    assert!(
        e.contains("evogs-no-such-dataset") && e.contains("missing"),
        "{e}"
    );

    let d = scene_copy("nojson");
    std::fs::remove_file(d.join("transforms_train.json")).expect("rm");
    let e = load(&d).expect_err("missing transforms");
    assert!(
        e.contains("transforms_train.json") && e.contains("missing"),
        "{e}"
    );

    let d = scene_copy("badjson");
    std::fs::write(
        d.join("transforms_train.json"),
        "{\"camera_angle_x\": 0.7, \"frames\": [",
    )
    .expect("write");
    let e = load(&d).expect_err("malformed JSON");
    assert!(
        e.contains("transforms_train.json") && e.contains("malformed JSON"),
        "{e}"
    );

    let d = scene_copy("nofield");
    edit_json(&d, |v| {
        v["frames"][1].as_object_mut().expect("obj").remove("time");
    });
    let e = load(&d).expect_err("missing time");
    assert!(
        e.contains("transforms_train.json") && e.contains("time"),
        "{e}"
    );

    let d = scene_copy("badtime");
    edit_json(&d, |v| {
        v["frames"][2]["time"] = serde_json::json!(1.5);
    });
    let e = load(&d).expect_err("time outside [0, 1]");
    assert!(
        e.contains("frames[2].time") && e.contains("outside [0, 1]"),
        "{e}"
    );

    let d = scene_copy("badcam");
    edit_json(&d, |v| {
        v["frames"][0]["transform_matrix"] = serde_json::json!([
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0]
        ]);
    });
    let e = load(&d).expect_err("a zero matrix is no camera pose");
    assert!(
        e.contains("transforms_train.json") && e.contains("frames[0].transform_matrix"),
        "{e}"
    );

    let d = scene_copy("noimage");
    std::fs::remove_file(d.join("train/r_001.png")).expect("rm");
    let e = load(&d).expect_err("missing image");
    assert!(e.contains("r_001.png") && e.contains("missing"), "{e}");

    let d = scene_copy("garbage");
    std::fs::write(d.join("train/r_001.png"), b"GIF89a not really").expect("write");
    let e = load(&d).expect_err("not a PNG");
    assert!(e.contains("r_001.png") && e.contains("PNG"), "{e}");

    let d = scene_copy("size");
    image::RgbaImage::new(64, 64)
        .save(d.join("train/r_002.png"))
        .expect("save");
    let e = load(&d).expect_err("wrong size");
    assert!(e.contains("r_002.png") && e.contains("64x64"), "{e}");

    let d = scene_copy("ply");
    std::fs::write(
        d.join("points3d.ply"),
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n",
    )
    .expect("write");
    let e = load(&d).expect_err("bad point cloud");
    assert!(e.contains("points3d.ply"), "{e}");
    for tag in [
        "nojson", "badjson", "nofield", "badtime", "badcam", "noimage", "garbage", "size", "ply",
    ] {
        let _ = std::fs::remove_dir_all(
            std::env::temp_dir().join(format!("evogs-ds-{tag}-{}", std::process::id())),
        );
    }
}

#[test]
fn a_byte_order_mark_is_read_past_and_the_data_identity_ignores_the_folder() {
    let plain = scene_copy("bom-plain");
    let marked = scene_copy("bom-marked");
    let p = marked.join("transforms_train.json");
    let mut bytes = vec![0xef, 0xbb, 0xbf];
    bytes.extend(std::fs::read(&p).expect("json"));
    std::fs::write(&p, bytes).expect("json");
    let a = load(&plain).expect("plain");
    let b = load(&marked).expect("with a byte-order mark");
    assert_eq!(a.train.len(), b.train.len());
    let (ia, ib) = (
        evogs::data::DataIdentity::of(&a),
        evogs::data::DataIdentity::of(&b),
    );
    assert!(ia.same_data(&ib), "{ia:?} {ib:?}");
    assert_ne!(ia.folder, ib.folder);
    // One training time changed: other data.
    edit_json(&plain, |v| {
        v["frames"][1]["time"] = serde_json::json!(0.123);
    });
    let c = load(&plain).expect("edited");
    assert!(!ia.same_data(&evogs::data::DataIdentity::of(&c)));
    std::fs::remove_dir_all(plain).ok();
    std::fs::remove_dir_all(marked).ok();
}
