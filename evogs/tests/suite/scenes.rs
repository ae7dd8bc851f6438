//! The procedural scenes: a small generated scene loads with the D-NeRF loader, its
//! `motion.json` reproduces the rendered Gaussians' positions, its masks cover the moving
//! body, and the trajectory error is zero for the true motion.

use evogs::data::{Dataset, LoadOptions, read_point_cloud};
use evogs::scenes::{
    BuiltScene, GroundTruth, Layout, Spacing, Variant, select, trajectory_error, write_scene,
};
use evogs_math::{Par, Vec3};
use evogs_splat::PinholeCamera;
use std::path::PathBuf;

fn small() -> Layout {
    Layout {
        size: 32,
        train_times: 6,
        test_times: 3,
        val_times: 2,
        future_times: 2,
        ring: 3,
        ring_times: 3,
    }
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("evogs-scenes-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn a_generated_scene_loads_and_its_ground_truth_reproduces_the_gaussians() {
    let spec = &select(&["throw".to_string()]).expect("known")[0];
    let scene = BuiltScene::new(spec, Spacing::default(), 5);
    let dir = temp("throw");
    let w = write_scene(
        &scene,
        Variant::Monocular,
        &small(),
        &dir,
        Par::Seq,
        |_, _| {},
    )
    .expect("written");
    assert_eq!(
        small().frame_count(Variant::Monocular),
        w.frames.iter().map(|(_, n)| n).sum::<usize>(),
        "frame count"
    );
    assert_eq!(
        w.frames,
        vec![("train", 6), ("val", 2), ("test", 3), ("future", 2)],
        "frames per split"
    );
    let ds = Dataset::load(&dir, &LoadOptions::default()).expect("the D-NeRF loader reads it");
    assert_eq!(ds.train.len(), 6, "train");
    assert_eq!(ds.test.len(), 3, "test");
    assert_eq!(ds.future.len(), 2, "future");
    assert!(
        ds.future.iter().all(|v| v.time > 1.0 && v.time <= 1.3),
        "future times"
    );
    assert!(
        ds.test.iter().all(|v| v.time > 0.0 && v.time < 1.0),
        "test times inside the window"
    );
    let (a, b) = ds.train_time_range();
    assert!(
        a.abs() < 1e-12 && (b - 1.0).abs() < 1e-12,
        "train times span [0, 1]"
    );
    let img = ds.train[0].image.as_ref().expect("decoded");
    assert_eq!((img.width(), img.height()), (32, 32), "size");

    // motion.json: the body points through the law give points3d.ply (t = 0) and the
    // rendered Gaussians at any t.
    let gt = GroundTruth::read(&dir.join("motion.json")).expect("motion.json");
    let points = read_point_cloud(&dir.join("points3d.ply")).expect("points");
    assert_eq!(
        points.positions.len(),
        scene.len(),
        "one vertex per Gaussian"
    );
    let moving: Vec<_> = gt.bodies.iter().filter(|b| b.moving).collect();
    assert_eq!(moving.len(), 1, "one moving body");
    for t in [0.0, 0.37, 1.21] {
        let splats = scene.splats_at(t, false);
        for body in &gt.bodies {
            for (k, &g) in body.gaussians.iter().enumerate() {
                let want = body.position(k, t);
                assert!(
                    (splats.means[g] - want).norm() < 1e-12,
                    "{} at {t}",
                    body.name
                );
                if t == 0.0 {
                    let p = points.positions[g];
                    let d = Vec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) - want;
                    assert!(d.norm() < 1e-5, "points3d.ply vertex {g}");
                }
            }
        }
    }
    // The sampled rigid transforms are the law's.
    let body = moving[0];
    for (i, &t) in gt.sample_times.iter().enumerate() {
        let (r, p) = body.law.world_from_body(t);
        let s = body.samples[i];
        assert!(
            (Vec3::from_array(s.translation) - p).norm() < 1e-15,
            "sample {i}"
        );
        assert_eq!(s.rotation, r.m, "sample {i}");
    }
    assert!(
        (gt.sample_times[0] + 0.3).abs() < 1e-12
            && (gt.sample_times.last().copied().unwrap_or(0.0) - 1.3).abs() < 1e-12,
        "samples span [-0.3, 1.3]"
    );

    // The motion mask covers the moving body's centre and not the far corner of the floor.
    for v in &ds.train {
        let mask_path = v.file.with_file_name(format!(
            "{}_motion.png",
            v.file.file_stem().and_then(|s| s.to_str()).expect("a name")
        ));
        let mask = image::open(&mask_path).expect("mask").to_luma8();
        assert_eq!(mask.dimensions(), (32, 32), "mask size");
        let cam = PinholeCamera::<f64>::from_dnerf(v.c2w, v.fov_x, 32, 32).expect("camera");
        let (_, centre) = body.law.world_from_body(v.time);
        let c = cam.world_to_camera(centre);
        let (u, w) = (cam.fx * c.x / c.z + cam.cx, cam.fy * c.y / c.z + cam.cy);
        #[allow(clippy::cast_possible_truncation, reason = "pixel")]
        let (u, w) = (u as u32, w as u32);
        if u < 32 && w < 32 {
            assert_eq!(
                mask.get_pixel(u, w).0[0],
                255,
                "{} at ({u}, {w})",
                mask_path.display()
            );
        }
        let covered = mask.pixels().filter(|p| p.0[0] == 255).count();
        assert!(covered > 0 && covered < 32 * 32 / 2, "{covered} pixels");
        assert!(
            mask.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255),
            "binary"
        );
    }

    // Trajectory error: the true motion scores 0, holding the state scores 1 (the error is
    // the distance travelled).
    let split = 0.75;
    let x0 = scene.splats_at(split, false).means;
    let truth = scene.splats_at(1.3, false).means;
    let e = trajectory_error(&gt, &x0, &truth, split, 1.3).expect("moving Gaussians");
    assert_eq!(
        e.gaussians,
        body.gaussians.len(),
        "the ball's Gaussians only"
    );
    assert!(e.mean_error < 1e-12 && e.mean_travel > 0.3, "{e:?}");
    let held = trajectory_error(&gt, &x0, &x0, split, 1.3).expect("moving Gaussians");
    assert!((held.relative - 1.0).abs() < 1e-12, "{held:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_multiview_variant_holds_out_one_ring_camera_and_is_deterministic() {
    let spec = &select(&["wave".to_string()]).expect("known")[0];
    let scene = BuiltScene::new(spec, Spacing::default(), 2);
    let dir = temp("wave");
    write_scene(
        &scene,
        Variant::Multiview,
        &small(),
        &dir,
        Par::Seq,
        |_, _| {},
    )
    .expect("written");
    let ds = Dataset::load(&dir, &LoadOptions::default()).expect("loads");
    assert_eq!(ds.train.len(), 2 * 3, "two ring cameras at three times");
    let all = ds.train.len() + ds.val.len() + ds.test.len() + ds.future.len();
    assert_eq!(small().frame_count(Variant::Multiview), all, "frame count");
    let test_cam = ds.test[0].c2w;
    assert!(ds.test.iter().all(|v| v.c2w == test_cam), "one test camera");
    assert!(
        ds.train.iter().all(|v| v.c2w != test_cam),
        "held out of training"
    );
    let again = temp("wave-again");
    write_scene(
        &scene,
        Variant::Multiview,
        &small(),
        &again,
        Par::Seq,
        |_, _| {},
    )
    .expect("again");
    for f in [
        "transforms_train.json",
        "test/c2_001.png",
        "test/c2_001_motion.png",
        "motion.json",
    ] {
        let a = std::fs::read(dir.join(f)).expect(f);
        let b = std::fs::read(again.join(f)).expect(f);
        assert!(a == b, "{f} differs between two runs");
    }
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&again);
}
