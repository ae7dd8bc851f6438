//! Training says where its initial Gaussians come from: the dataset's `points3d.ply`, or
//! random points with the reason (no file, a file without vertices, `init.use_points =
//! false`); it never falls back silently.

use crate::common;

use evogs_cli::app::paths::shipped_scene;
use evogs_cli::app::train::{TrainArgs, train};

#[test]
fn the_source_of_the_initial_gaussians_is_reported() {
    let dir = common::scratch("init-note");
    let data = dir.join("scene");
    common::copy_tree(&shipped_scene(), &data);
    let schedule = "[schedule]\nwarmup_iters = 1\niterations = 2\ncurriculum_iters = 0\n";
    let note = |name: &str, extra: &str| {
        let cfg = common::tiny_config(&dir, &format!("{schedule}\n{extra}"));
        let mut infos = common::Infos::default();
        train(
            &TrainArgs {
                data: Some(data.clone()),
                out: dir.join(name),
                config: Some(cfg),
                skip_outputs: true,
                ..TrainArgs::default()
            },
            &mut infos,
        )
        .expect("trains");
        infos
            .0
            .into_iter()
            .find(|m| m.starts_with("initial Gaussians"))
            .expect("a note on the initial Gaussians")
    };
    let ply = data.join("points3d.ply");
    let m = note("with-points", "");
    assert!(
        m.contains("points from") && m.contains("points3d.ply"),
        "{m}"
    );
    let m = note(
        "not-used",
        "[init]\nuse_points = false\nrandom_points = 300\n",
    );
    assert!(
        m.contains("use_points = false") && m.contains("300 random points"),
        "{m}"
    );
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    )
    .expect("empty ply");
    let m = note("empty", "");
    assert!(
        m.contains("has no vertices") && m.contains("random points"),
        "{m}"
    );
    std::fs::remove_file(&ply).expect("remove");
    let m = note("missing", "");
    assert!(
        m.contains("no ") && m.contains("points3d.ply in the dataset"),
        "{m}"
    );
    std::fs::remove_dir_all(dir).ok();
}
