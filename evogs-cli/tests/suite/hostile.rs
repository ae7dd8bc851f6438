//! The `evogs` binary against well over a hundred bad inputs, all made here: malformed
//! datasets (D-NeRF and multi-view), point clouds, configurations, checkpoints, reference
//! files and arguments. For each: a non-zero exit that is not a panic, exactly one error
//! line on stderr that names the file or flag and the problem, and no output left behind
//! (no run folder, file or temporary file where the command would have written).

#![allow(
    clippy::semicolon_if_nothing_returned,
    reason = "the case table holds one-expression edits"
)]

use crate::common;

use evogs::run::archive::Archive;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// An edit of a transforms file.
type JsonEdit = Box<dyn Fn(&mut serde_json::Value)>;
/// An edit of a dataset folder.
type FolderEdit = Box<dyn Fn(&Path)>;

/// One bad invocation: its arguments, the words its error line must contain, and the paths
/// that must not exist afterwards.
struct Case {
    name: String,
    args: Vec<OsString>,
    expect: Vec<String>,
    absent: Vec<PathBuf>,
}

/// Builds cases for one scratch folder.
struct Cases {
    root: PathBuf,
    list: Vec<Case>,
    next: usize,
}

impl Cases {
    fn new(root: PathBuf) -> Self {
        Self {
            root,
            list: Vec::new(),
            next: 0,
        }
    }

    /// A fresh folder for one case's inputs.
    fn dir(&mut self, tag: &str) -> PathBuf {
        self.next += 1;
        let d = self.root.join(format!("{:03}-{tag}", self.next));
        std::fs::create_dir_all(&d).expect("case folder");
        d
    }

    fn add(
        &mut self,
        name: &str,
        args: &[&dyn AsRef<std::ffi::OsStr>],
        expect: &[&str],
        absent: &[&Path],
    ) {
        self.list.push(Case {
            name: name.to_string(),
            args: args.iter().map(|a| a.as_ref().to_os_string()).collect(),
            expect: expect.iter().map(|s| (*s).to_string()).collect(),
            absent: absent.iter().map(|p| p.to_path_buf()).collect(),
        });
    }
}

/// A small D-NeRF scene: three training frames, one test frame, the point cloud.
fn small_scene(dst: &Path) {
    let src = evogs_cli::app::paths::shipped_scene();
    for (split, keep) in [("train", 3), ("test", 1)] {
        std::fs::create_dir_all(dst.join(split)).expect("split folder");
        let name = format!("transforms_{split}.json");
        let text = std::fs::read_to_string(src.join(&name)).expect("json");
        let mut v: serde_json::Value = serde_json::from_str(&text).expect("json");
        let frames = v["frames"].as_array_mut().expect("frames");
        frames.truncate(keep);
        for f in frames.iter() {
            let rel = f["file_path"].as_str().expect("path").to_string() + ".png";
            std::fs::copy(src.join(&rel), dst.join(&rel)).expect("frame");
        }
        std::fs::write(dst.join(name), serde_json::to_string(&v).expect("json")).expect("write");
    }
    std::fs::copy(src.join("points3d.ply"), dst.join("points3d.ply")).expect("points");
}

fn edit_json(path: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("json");
    f(&mut v);
    std::fs::write(path, serde_json::to_string(&v).expect("json")).expect("write");
}

/// A binary little-endian PLY header for `x y z` floats and `n` declared vertices.
fn ply_header(n: &str) -> Vec<u8> {
    format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    )
    .into_bytes()
}

fn ply_body(points: &[[f32; 3]]) -> Vec<u8> {
    points
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// A `.npy` file of little-endian f64 values with the given shape.
fn npy(shape: &str, values: &[f64]) -> Vec<u8> {
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&u16::try_from(header.len()).expect("short").to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    out
}

/// The shipped small multi-view scene (copied).
fn mv_scene(dst: &Path) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/toys-mv-mini");
    common::copy_tree(&src, dst);
}

/// The tiny model with a case's sections: a section the case names replaces the model's
/// own, so the file has no duplicate tables (which would be a different error).
fn merged_config(case: &str) -> String {
    let mut out = String::new();
    for block in common::TINY_MODEL
        .split("\n[")
        .filter(|b| !b.trim().is_empty())
    {
        let block = if block.starts_with('[') {
            block.to_string()
        } else {
            format!("[{block}")
        };
        let head = block.lines().next().unwrap_or_default().to_string();
        if !case.contains(&head) {
            out.push_str(&block);
            out.push('\n');
        }
    }
    out.push_str(case);
    out
}

/// Runs one case; `Err` describes how it failed the contract.
fn check(case: &Case) -> Result<(), String> {
    let out = Command::new(env!("CARGO_BIN_EXE_evogs"))
        .args(&case.args)
        .env("NO_COLOR", "1")
        .output()
        .map_err(|e| format!("cannot run: {e}"))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    let code = out.status.code();
    if out.status.success() {
        return Err("exited 0".into());
    }
    if code == Some(101) || stderr.contains("panicked") {
        return Err(format!("panicked: {stderr}"));
    }
    if code.is_none() {
        return Err(format!("killed by a signal: {stderr}"));
    }
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("Error") || l.starts_with("error"))
        .collect();
    if errors.len() != 1 || stderr.contains("Caused by") {
        return Err(format!("not exactly one error line: {stderr}"));
    }
    let line = errors[0];
    if line.contains("   ") {
        return Err(format!("the error line holds a run of spaces: {line:?}"));
    }
    for w in &case.expect {
        if !line.contains(w.as_str()) {
            return Err(format!("the error line lacks `{w}`: {line}"));
        }
    }
    for p in &case.absent {
        if p.exists() {
            return Err(format!("{} was left behind ({line})", p.display()));
        }
        if let (Some(dir), Some(name)) = (p.parent(), p.file_name()) {
            let tmp = format!(".{}.tmp-", name.to_string_lossy());
            if let Ok(rd) = std::fs::read_dir(dir) {
                for e in rd.flatten() {
                    if e.file_name().to_string_lossy().starts_with(&tmp) {
                        return Err(format!("temporary {} left behind", e.path().display()));
                    }
                }
            }
        }
    }
    Ok(())
}

/// Sets entry `k` (0..17) of the first camera's row of `DIR/poses_bounds.npy` (4: the image
/// height, 9: the width, 14: the focal length).
fn set_pose_entry(dir: &Path, k: usize, value: f64) {
    let path = dir.join("poses_bounds.npy");
    let mut b = std::fs::read(&path).expect("poses");
    let rows = b.len() - 128;
    let at = b.len() - rows + 8 * k;
    assert_eq!(rows % (17 * 8), 0, "a 128-byte header");
    b[at..at + 8].copy_from_slice(&value.to_le_bytes());
    std::fs::write(&path, b).expect("poses");
}

fn build(c: &mut Cases) {
    let root = c.root.clone();
    let scene = root.join("scene");
    small_scene(&scene);
    let tiny = common::tiny_config(
        &root,
        "[schedule]\nwarmup_iters = 1\niterations = 2\ncurriculum_iters = 0\n",
    );
    let run = common::tiny_run(&root);
    let out = root.join("out-run");

    // ---- arguments
    let d = &scene;
    let bad_args: &[(&str, Vec<&str>, &[&str])] = &[
        (
            "iters negative",
            vec!["train", "--iters", "-5"],
            &["--iters", "-5"],
        ),
        (
            "iters zero",
            vec!["train", "--iters", "0"],
            &["--iters", "0"],
        ),
        (
            "iters text",
            vec!["train", "--iters", "many"],
            &["--iters", "many"],
        ),
        ("seed negative", vec!["train", "--seed", "-1"], &["--seed"]),
        (
            "unknown motion",
            vec!["train", "--motion", "warp"],
            &["--motion", "warp"],
        ),
        (
            "unknown protocol",
            vec!["train", "--protocol", "sometimes"],
            &["--protocol", "sometimes"],
        ),
        (
            "unknown format",
            vec!["train", "--format", "colmap"],
            &["--format", "colmap"],
        ),
        (
            "resume and force",
            vec!["train", "--resume", "--force"],
            &["--force"],
        ),
        ("study seeds 0", vec!["study", "--seeds", "0"], &["--seeds"]),
        ("study jobs 0", vec!["study", "--jobs", "0"], &["--jobs"]),
        (
            "study seeds huge",
            vec!["study", "--seeds", "18446744073709551615"],
            &["--seeds 18446744073709551615", "at most 10000"],
        ),
        (
            "study seeds beyond the run bound",
            vec!["study", "--seeds", "5000", "--motions", "velocity,static"],
            &["at most 10000"],
        ),
        (
            "study jobs negative",
            vec!["study", "--jobs", "-2"],
            &["--jobs"],
        ),
        (
            "eval split",
            vec!["eval", "--run", "r", "--split", "everything"],
            &["--split", "everything"],
        ),
        (
            "render missing out",
            vec!["render", "--run", "r"],
            &["--out"],
        ),
        (
            "export time text",
            vec!["export", "--run", "r", "--time", "noon", "--out", "x.ply"],
            &["--time", "noon"],
        ),
        (
            "check-order stepper",
            vec!["check-order", "--stepper", "rk9"],
            &["--stepper", "rk9"],
        ),
        ("unknown subcommand", vec!["fly"], &["fly"]),
        (
            "unknown flag",
            vec!["train", "--speed", "fast"],
            &["--speed"],
        ),
        ("verify no files", vec!["verify"], &["FILES"]),
    ];
    for (name, args, expect) in bad_args {
        let a: Vec<&dyn AsRef<std::ffi::OsStr>> = args
            .iter()
            .map(|s| s as &dyn AsRef<std::ffi::OsStr>)
            .collect();
        c.add(name, &a, expect, &[]);
    }
    let ply_out = root.join("never.ply");
    for (name, t) in [
        ("export nan", "nan"),
        ("export inf", "inf"),
        ("export -inf", "-inf"),
        ("export 1e308", "1e308"),
        ("export -1e6", "-1e6"),
        ("export 1000", "1000"),
    ] {
        c.add(
            name,
            &[&"export", &"--run", &run, &"--time", &t, &"--out", &ply_out],
            &["--time"],
            &[&ply_out],
        );
    }
    let seq_out = root.join("never-sequence");
    c.add(
        "export time and times",
        &[
            &"export", &"--run", &run, &"--time", &"0.5", &"--times", &"0:1:2", &"--out", &seq_out,
        ],
        &["--time"],
        &[&seq_out],
    );
    c.add(
        "export neither time",
        &[&"export", &"--run", &run, &"--out", &seq_out],
        &["--time"],
        &[&seq_out],
    );
    c.add(
        "export times far",
        &[
            &"export", &"--run", &run, &"--times", &"0:1e9:2", &"--out", &seq_out,
        ],
        &["--times"],
        &[&seq_out],
    );
    c.add(
        "export times zero",
        &[
            &"export", &"--run", &run, &"--times", &"0:1:0", &"--out", &seq_out,
        ],
        &["--times"],
        &[&seq_out],
    );
    let frames_out = root.join("never-frames");
    for (name, spec, word) in [
        ("times two parts", "0:1", "0:1"),
        ("times text", "a:b:c", "a:b:c"),
        ("times zero frames", "0:1:0", "0:1:0"),
        ("times nan", "nan:1:2", "nan:1:2"),
        ("times inf", "0:inf:2", "0:inf:2"),
        ("times negative count", "0:1:-3", "0:1:-3"),
        ("times far past", "-1e6:0:2", "--times"),
        ("times far future", "0:1e9:2", "--times"),
    ] {
        c.add(
            name,
            &[
                &"render",
                &"--run",
                &run,
                &"--out",
                &frames_out,
                &"--times",
                &spec,
                &"--data",
                d,
            ],
            &[word],
            &[&frames_out],
        );
    }
    for (name, camera) in [
        ("camera unknown", "sideways"),
        ("camera bare cam", "cam"),
        ("camera letters", "camXY"),
    ] {
        c.add(
            name,
            &[
                &"render",
                &"--run",
                &run,
                &"--out",
                &frames_out,
                &"--camera",
                &camera,
                &"--data",
                d,
            ],
            &[camera],
            &[&frames_out],
        );
    }
    c.add(
        "rig camera on a monocular scene",
        &[
            &"render",
            &"--run",
            &run,
            &"--out",
            &frames_out,
            &"--camera",
            &"rig",
            &"--data",
            d,
        ],
        &["rig"],
        &[&frames_out],
    );
    for (name, range) in [
        ("eval range empty", "5:6"),
        ("eval range reversed", "1:0"),
        ("eval range nan", "nan:1"),
        ("eval range one number", "0.5"),
    ] {
        c.add(
            name,
            &[&"eval", &"--run", &run, &"--time-range", &range],
            &["--time-range"],
            &[&run.join("metrics-test-t5-6.json")],
        );
    }
    for (name, mask, field, word) in [
        ("mask unknown", "cone:0,0,0,1", "translate:0,0,1", "cone"),
        ("mask nan", "sphere:nan,0,0,1", "translate:0,0,1", "nan"),
        (
            "mask negative radius",
            "sphere:0,0,0,-1",
            "translate:0,0,1",
            "R > 0",
        ),
        ("field unknown", "sphere:0,0,0,1", "teleport:1", "teleport"),
        ("field inf", "sphere:0,0,0,1", "translate:0,inf,1", "inf"),
        (
            "field short",
            "sphere:0,0,0,1",
            "translate:0,1",
            "translate",
        ),
    ] {
        let o = root.join(format!("never-inject-{}", name.replace(' ', "-")));
        c.add(
            name,
            &[
                &"inject", &"--run", &run, &"--out", &o, &"--mask", &mask, &"--field", &field,
                &"--data", d,
            ],
            &[word],
            &[&o],
        );
    }

    // ---- configurations (a valid scene, a bad configuration: no run folder appears)
    let configs: &[(&str, &str, &str)] = &[
        (
            "random points beyond memory",
            "[init]\nrandom_points = 99999999999\n",
            "init.random_points = 99999999999",
        ),
        (
            "max gaussians beyond memory",
            "[densify]\nmax_gaussians = 99999999999999\n",
            "GiB",
        ),
        (
            "anchors beyond memory",
            "[dynamics]\nanchors = 100000\n",
            "dynamics.anchors = 100000",
        ),
        (
            "motion as a number",
            "[dynamics]\nmotion = 3\n",
            "dynamics.motion: expected one of its names in quotes, got 3",
        ),
        (
            "protocol as a boolean",
            "[data]\nprotocol = true\n",
            "data.protocol: expected one of its names in quotes",
        ),
        (
            "format as a number",
            "[data]\nformat = 2\n",
            "data.format: expected one of its names in quotes",
        ),
        (
            "hop law as a number",
            "[hop]\nlaw = 2\n",
            "hop.law: expected one of its names in quotes",
        ),
        (
            "hexplane resolution beyond memory",
            "[field.hexplane]\nresolution = [100000, 100000, 100000, 100000]\n",
            "GiB",
        ),
        (
            "width as text",
            "[field]\nwidth = \"wide\"\n",
            "field.width",
        ),
        (
            "a key of the top table after the last table",
            "seed = -4\n",
            "field.hexplane.seed: unknown field",
        ),
        (
            "background as text",
            "[data]\nbackground = \"white\"\n",
            "data.background",
        ),
        (
            "position lr nan",
            "[optim]\nposition_lr_init = nan\n",
            "position_lr_init",
        ),
        (
            "feature lr nan",
            "[optim]\nfeature_lr = nan\n",
            "feature_lr",
        ),
        (
            "opacity lr inf",
            "[optim]\nopacity_lr = inf\n",
            "opacity_lr",
        ),
        (
            "scaling lr negative",
            "[optim]\nscaling_lr = -0.1\n",
            "scaling_lr",
        ),
        (
            "coherence nan",
            "[loss]\nlambda_coherence = nan\n",
            "lambda_coherence",
        ),
        (
            "random extent negative",
            "[init]\nrandom_extent = -1\n",
            "random_extent",
        ),
        (
            "random points zero",
            "[init]\nuse_points = false\nrandom_points = 0\n",
            "random_points",
        ),
        (
            "grad threshold negative",
            "[densify]\ngrad_threshold = -1\n",
            "grad_threshold",
        ),
        (
            "min opacity above one",
            "[densify]\nmin_opacity = 1.5\n",
            "min_opacity",
        ),
        (
            "background nan",
            "[data]\nbackground = [nan, 1.0, 1.0]\n",
            "background",
        ),
        (
            "background two values",
            "[data]\nbackground = [1.0, 1.0]\n",
            "background",
        ),
        ("downscale zero", "[data]\ndownscale = 0\n", "downscale"),
        (
            "split time two",
            "[data]\nprotocol = \"future\"\nsplit_time = 2.0\n",
            "split_time",
        ),
        (
            "stride zero",
            "[data]\nprotocol = \"sparse\"\nstride = 0\n",
            "stride",
        ),
        (
            "iterations as text",
            "[schedule]\niterations = \"many\"\n",
            "iterations",
        ),
        ("unknown section", "[turbo]\nboost = true\n", "turbo"),
        (
            "unknown key",
            "[optim]\nlearning_rate = 0.1\n",
            "learning_rate",
        ),
        ("not toml", "[optim\nfeature_lr = 0.1\n", "tiny.toml"),
        ("field width zero", "[field]\nwidth = 0\n", "width"),
        ("field width 1e9", "[field]\nwidth = 1000000000\n", "GiB"),
        (
            "field width 1e10",
            "[field]\nwidth = 10000000000\n",
            "does not fit in memory",
        ),
        (
            "hexplane resolution 100000",
            "[field.hexplane]\nresolution = [100000, 100000, 100000, 16]\n",
            "GiB",
        ),
        (
            "hexplane multires zero",
            "[field.hexplane]\nmultires = [0]\n",
            "multires",
        ),
        (
            "coherence with no samples",
            "[loss]\nlambda_coherence = 0.01\ncoherence_samples = 0\n",
            "coherence_samples",
        ),
        ("cache zero", "[data]\ncache_mb = 0\n", "cache_mb"),
        ("sh degree nine", "[init]\nsh_degree = 9\n", "sh_degree"),
        ("unknown method", "[dynamics]\nmethod = \"rk9\"\n", "rk9"),
        (
            "checkpoint minutes negative",
            "[schedule]\ncheckpoint_minutes = -1.0\n",
            "checkpoint_minutes",
        ),
    ];
    for (name, text, word) in configs {
        let dir = c.dir("config");
        let cfg = dir.join("tiny.toml");
        std::fs::write(&cfg, merged_config(text)).expect("config");
        let o = dir.join("run");
        c.add(
            name,
            &[&"train", &"--data", d, &"--out", &o, &"--config", &cfg],
            &[word, "tiny.toml"],
            &[&o],
        );
    }
    let o = root.join("never-run-split");
    c.add(
        "flag split time two",
        &[
            &"train",
            &"--data",
            d,
            &"--out",
            &o,
            &"--config",
            &tiny,
            &"--protocol",
            &"future",
            &"--split-time",
            &"2",
        ],
        &["split_time"],
        &[&o],
    );
    let missing_cfg = root.join("no-such.toml");
    c.add(
        "config missing",
        &[
            &"train",
            &"--data",
            d,
            &"--out",
            &out,
            &"--config",
            &missing_cfg,
        ],
        &["no-such.toml"],
        &[&out],
    );
    c.add(
        "preset unknown",
        &[
            &"train",
            &"--data",
            d,
            &"--out",
            &out,
            &"--preset",
            &"turbo",
        ],
        &["turbo"],
        &[&out],
    );

    // ---- D-NeRF datasets
    let json_edits: Vec<(&str, JsonEdit, &str)> = vec![
        (
            "no frames",
            Box::new(|v| v["frames"] = serde_json::json!([])),
            "frames",
        ),
        (
            "frames not a list",
            Box::new(|v| v["frames"] = serde_json::json!(3)),
            "frames",
        ),
        (
            "no camera angle",
            Box::new(|v| {
                v.as_object_mut().expect("object").remove("camera_angle_x");
            }),
            "camera_angle_x",
        ),
        (
            "camera angle zero",
            Box::new(|v| v["camera_angle_x"] = serde_json::json!(0.0)),
            "camera_angle_x",
        ),
        (
            "camera angle negative",
            Box::new(|v| v["camera_angle_x"] = serde_json::json!(-0.7)),
            "camera_angle_x",
        ),
        (
            "camera angle tiny",
            Box::new(|v| v["camera_angle_x"] = serde_json::json!(1e-30)),
            "camera_angle_x",
        ),
        (
            "camera angle pi",
            Box::new(|v| v["camera_angle_x"] = serde_json::json!(3.2)),
            "camera_angle_x",
        ),
        (
            "camera angle text",
            Box::new(|v| v["camera_angle_x"] = serde_json::json!("wide")),
            "camera_angle_x",
        ),
        (
            "matrix three rows",
            Box::new(|v| {
                v["frames"][0]["transform_matrix"]
                    .as_array_mut()
                    .expect("rows")
                    .truncate(3);
            }),
            "transform_matrix",
        ),
        (
            "matrix nan",
            Box::new(|v| v["frames"][0]["transform_matrix"][0][3] = serde_json::json!("nan")),
            "transform_matrix",
        ),
        (
            "matrix huge",
            Box::new(|v| v["frames"][0]["transform_matrix"][0][3] = serde_json::json!(1e300)),
            "transform_matrix",
        ),
        (
            "matrix singular",
            Box::new(|v| {
                v["frames"][0]["transform_matrix"] =
                    serde_json::json!([[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]])
            }),
            "transform_matrix",
        ),
        (
            "time text",
            Box::new(|v| v["frames"][1]["time"] = serde_json::json!("noon")),
            "time",
        ),
        (
            "time huge",
            Box::new(|v| v["frames"][1]["time"] = serde_json::json!(1e300)),
            "time",
        ),
        (
            "missing image",
            Box::new(|v| v["frames"][2]["file_path"] = serde_json::json!("./train/nothing")),
            "nothing",
        ),
        (
            "file path number",
            Box::new(|v| v["frames"][2]["file_path"] = serde_json::json!(7)),
            "file_path",
        ),
        (
            "escaping path",
            Box::new(|v| v["frames"][2]["file_path"] = serde_json::json!("../../../../etc/passwd")),
            "passwd",
        ),
        (
            "file path ending in a slash",
            Box::new(|v| v["frames"][1]["file_path"] = serde_json::json!("./train/")),
            "frames[1].file_path `./train/` names a folder",
        ),
        (
            "empty file path",
            Box::new(|v| v["frames"][2]["file_path"] = serde_json::json!("")),
            "frames[2].file_path is empty",
        ),
        (
            "blank file path",
            Box::new(|v| v["frames"][1]["file_path"] = serde_json::json!("  ")),
            "frames[1].file_path is empty",
        ),
        (
            "file path that is the dataset folder",
            Box::new(|v| v["frames"][0]["file_path"] = serde_json::json!(".")),
            "frames[0].file_path `.` names a folder",
        ),
    ];
    for (name, edit, word) in json_edits {
        let dir = c.dir("dnerf");
        small_scene(&dir);
        edit_json(&dir.join("transforms_train.json"), edit);
        let o = dir.join("run");
        c.add(
            name,
            &[&"train", &"--data", &dir, &"--out", &o, &"--config", &tiny],
            &[word],
            &[&o],
        );
    }
    let file_edits: &[(&str, &str, &[u8], &str)] = &[
        (
            "train json garbage",
            "transforms_train.json",
            b"{ frames: oops",
            "transforms_train.json",
        ),
        (
            "train json empty",
            "transforms_train.json",
            b"",
            "transforms_train.json",
        ),
        (
            "train json a list",
            "transforms_train.json",
            b"[1, 2, 3]",
            "transforms_train.json",
        ),
        (
            "test json garbage",
            "transforms_test.json",
            b"not json",
            "transforms_test.json",
        ),
        (
            "frame not a png",
            "train/r_000.png",
            b"GIF89a not a png",
            "r_000.png",
        ),
        ("frame empty", "train/r_000.png", b"", "r_000.png"),
        (
            "frame truncated png",
            "train/r_000.png",
            b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR",
            "r_000.png",
        ),
    ];
    for (name, file, bytes, word) in file_edits {
        let dir = c.dir("dnerf-file");
        small_scene(&dir);
        let target = if file.starts_with("train/") {
            // The first training frame, whatever its name.
            let v: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(dir.join("transforms_train.json")).expect("json"),
            )
            .expect("json");
            dir.join(
                v["frames"][0]["file_path"]
                    .as_str()
                    .expect("path")
                    .to_string()
                    + ".png",
            )
        } else {
            dir.join(file)
        };
        let word = if file.starts_with("train/") {
            target
                .file_name()
                .expect("name")
                .to_string_lossy()
                .into_owned()
        } else {
            (*word).to_string()
        };
        std::fs::write(&target, bytes).expect("write");
        let o = dir.join("run");
        c.add(
            name,
            &[&"train", &"--data", &dir, &"--out", &o, &"--config", &tiny],
            &[word.as_str()],
            &[&o],
        );
    }
    {
        let dir = c.dir("dnerf-size");
        small_scene(&dir);
        let v: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("transforms_train.json")).expect("json"),
        )
        .expect("json");
        let p = dir.join(
            v["frames"][1]["file_path"]
                .as_str()
                .expect("path")
                .to_string()
                + ".png",
        );
        image::RgbaImage::new(37, 21).save(&p).expect("small frame");
        let o = dir.join("run");
        let name = p.file_name().expect("name").to_string_lossy().into_owned();
        c.add(
            "frame of another size",
            &[&"train", &"--data", &dir, &"--out", &o, &"--config", &tiny],
            &[name.as_str()],
            &[&o],
        );
    }
    let empty = c.dir("empty-folder");
    let o = empty.join("run");
    c.add(
        "empty data folder",
        &[
            &"train",
            &"--data",
            &empty,
            &"--out",
            &o,
            &"--config",
            &tiny,
        ],
        &["transforms_train.json"],
        &[&o],
    );
    let nowhere = root.join("no-such-scene");
    c.add(
        "missing data folder",
        &[
            &"train",
            &"--data",
            &nowhere,
            &"--out",
            &out,
            &"--config",
            &tiny,
        ],
        &["no-such-scene"],
        &[&out],
    );

    // ---- point clouds (points3d.ply of an otherwise good scene)
    let mut huge = ply_header("1");
    huge.extend(ply_body(&[[1e30, 0.0, 0.0]]));
    let mut nan = ply_header("2");
    nan.extend(ply_body(&[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0]]));
    let mut trailing = ply_header("1");
    trailing.extend(ply_body(&[[0.0, 0.0, 0.0]]));
    trailing.extend_from_slice(b"extra");
    let mut short = ply_header("3");
    short.extend(ply_body(&[[0.0, 0.0, 0.0]]));
    let plys: Vec<(&str, Vec<u8>, &str)> = vec![
        ("ply four billion", ply_header("4000000000"), "points3d.ply"),
        ("ply u64 max", ply_header("18446744073709551615"), "points3d.ply"),
        ("ply negative count", ply_header("-3"), "points3d.ply"),
        ("ply trailing bytes", trailing, "points3d.ply"),
        ("ply truncated body", short, "points3d.ply"),
        ("ply nan", nan, "points3d.ply"),
        ("ply far point", huge, "points3d.ply"),
        ("ply not a ply", b"solid cube\nfacet normal 0 0 1\n".to_vec(), "points3d.ply"),
        ("ply no end header", b"ply\nformat ascii 1.0\nelement vertex 1\n".to_vec(), "points3d.ply"),
        ("ply ascii extra column", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0 7\n".to_vec(), "points3d.ply"),
        ("ply ascii missing column", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0\n".to_vec(), "points3d.ply"),
        ("ply ascii text value", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 zero 0\n".to_vec(), "points3d.ply"),
        ("ply no x", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec(), "points3d.ply"),
        ("ply unknown format", b"ply\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n".to_vec(), "points3d.ply"),
        ("ply unknown type", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n0\n".to_vec(), "points3d.ply"),
        ("ply empty file", Vec::new(), "points3d.ply"),
    ];
    for (name, bytes, word) in plys {
        let dir = c.dir("ply");
        small_scene(&dir);
        std::fs::write(dir.join("points3d.ply"), bytes).expect("ply");
        let o = dir.join("run");
        c.add(
            name,
            &[&"train", &"--data", &dir, &"--out", &o, &"--config", &tiny],
            &[word],
            &[&o],
        );
    }

    // ---- multi-view datasets
    let mv_cases: Vec<(&str, FolderEdit, &str)> = vec![
        (
            "poses garbage",
            Box::new(|d| std::fs::write(d.join("poses_bounds.npy"), b"garbage").expect("w")),
            "poses_bounds.npy",
        ),
        (
            "poses wrong width",
            Box::new(|d| {
                std::fs::write(d.join("poses_bounds.npy"), npy("(5, 16)", &[1.0; 80])).expect("w")
            }),
            "poses_bounds.npy",
        ),
        (
            "poses wrong rows",
            Box::new(|d| {
                std::fs::write(d.join("poses_bounds.npy"), npy("(3, 17)", &[1.0; 51])).expect("w")
            }),
            "poses_bounds.npy",
        ),
        (
            "poses nan",
            Box::new(|d| {
                let mut v = vec![0.0; 85];
                v[0] = f64::NAN;
                std::fs::write(d.join("poses_bounds.npy"), npy("(5, 17)", &v)).expect("w");
            }),
            "poses_bounds.npy",
        ),
        (
            "poses truncated",
            Box::new(|d| {
                let b = std::fs::read(d.join("poses_bounds.npy")).expect("r");
                std::fs::write(d.join("poses_bounds.npy"), &b[..b.len() - 9]).expect("w");
            }),
            "poses_bounds.npy",
        ),
        (
            "a camera folder too few",
            Box::new(|d| std::fs::remove_dir_all(d.join("cam00")).expect("rm")),
            "camera folders",
        ),
        (
            "no cam00",
            Box::new(|d| {
                std::fs::remove_dir_all(d.join("cam00")).expect("rm");
                let b = std::fs::read(d.join("poses_bounds.npy")).expect("r");
                let (header, body) = b.split_at(b.len() - 5 * 17 * 8);
                let mut out = header.to_vec();
                let at = out.windows(7).position(|w| w == b"(5, 17)").expect("shape");
                out[at + 1] = b'4';
                out.extend_from_slice(&body[17 * 8..]);
                std::fs::write(d.join("poses_bounds.npy"), out).expect("w");
            }),
            "cam00",
        ),
        (
            "missing frame",
            Box::new(|d| std::fs::remove_file(d.join("cam02/images/0003.png")).expect("rm")),
            "cam02",
        ),
        (
            "frame count differs",
            Box::new(|d| {
                std::fs::copy(
                    d.join("cam04/images/0000.png"),
                    d.join("cam04/images/0099.png"),
                )
                .map(|_| ())
                .expect("cp")
            }),
            "cam04",
        ),
        (
            "frame size differs",
            Box::new(|d| {
                image::RgbImage::new(13, 7)
                    .save(d.join("cam06/images/0002.png"))
                    .expect("save")
            }),
            "0002.png",
        ),
        (
            "frame not a png",
            Box::new(|d| std::fs::write(d.join("cam08/images/0001.png"), b"nope").expect("w")),
            "0001.png",
        ),
        (
            "image height of 9e15 pixels",
            Box::new(|d| set_pose_entry(d, 4, 9e15)),
            "H = 9000000000000000 pixels is too large",
        ),
        (
            "image width of a half pixel",
            Box::new(|d| set_pose_entry(d, 9, 0.5)),
            "W = 0.5 is not a positive number of pixels",
        ),
        (
            "image height not whole",
            Box::new(|d| set_pose_entry(d, 4, 200.5)),
            "H = 200.5 is not a whole number",
        ),
        (
            "times file short",
            Box::new(|d| std::fs::write(d.join("times.txt"), "0.0\n0.5\n").expect("w")),
            "times.txt",
        ),
    ];
    for (name, edit, word) in mv_cases {
        let dir = c.dir("mv");
        mv_scene(&dir);
        edit(&dir);
        let o = dir.join("run");
        c.add(
            name,
            &[
                &"train",
                &"--data",
                &dir,
                &"--out",
                &o,
                &"--config",
                &tiny,
                &"--format",
                &"n3dv",
            ],
            &[word],
            &[&o],
        );
    }

    // ---- checkpoints (a copy of the tiny run, damaged)
    let good = std::fs::read(run.join("checkpoint.safetensors")).expect("checkpoint");
    let mut flipped = good.clone();
    flipped[0] ^= 0xff;
    let nan_means = {
        let mut a = Archive::from_bytes(&good).expect("archive");
        let mut m = a.f32("canonical.means").expect("means").to_vec();
        m[4] = f32::NAN;
        a.put_f32("canonical.means", &m);
        let p = root.join("nan.bin");
        a.write(&p).expect("write");
        std::fs::read(&p).expect("read")
    };
    let short_field = {
        let mut a = Archive::from_bytes(&good).expect("archive");
        let f = a.f32("field").expect("field").to_vec();
        a.put_f32("field", &f[..f.len() / 2]);
        let p = root.join("short.bin");
        a.write(&p).expect("write");
        std::fs::read(&p).expect("read")
    };
    let damaged: Vec<(&str, Vec<u8>)> = vec![
        ("checkpoint empty", Vec::new()),
        ("checkpoint half", good[..good.len() / 2].to_vec()),
        ("checkpoint one byte short", good[..good.len() - 1].to_vec()),
        ("checkpoint magic", flipped),
        (
            "checkpoint garbage",
            b"definitely not a checkpoint".to_vec(),
        ),
        ("checkpoint nan means", nan_means),
        ("checkpoint short field", short_field),
    ];
    for (name, bytes) in damaged {
        let r = c.dir("ckpt");
        common::copy_tree(&run, &r);
        std::fs::write(r.join("checkpoint.safetensors"), &bytes).expect("damage");
        let ply = r.join("x.ply");
        let frames = r.join("frames");
        c.add(
            &format!("{name}: export"),
            &[&"export", &"--run", &r, &"--time", &"0.5", &"--out", &ply],
            &["checkpoint.safetensors"],
            &[&ply],
        );
        c.add(
            &format!("{name}: render"),
            &[
                &"render", &"--run", &r, &"--out", &frames, &"--times", &"0:1:2", &"--data", d,
            ],
            &["checkpoint.safetensors"],
            &[&frames],
        );
        c.add(
            &format!("{name}: eval"),
            &[&"eval", &"--run", &r, &"--data", d],
            &["checkpoint.safetensors"],
            &[&r.join("metrics-test.json")],
        );
    }
    {
        let r = c.dir("no-ckpt");
        let ply = r.join("x.ply");
        c.add(
            "run without checkpoint",
            &[&"export", &"--run", &r, &"--time", &"0.5", &"--out", &ply],
            &["checkpoint.safetensors"],
            &[&ply],
        );
        let r2 = c.dir("resume-nothing");
        c.add(
            "resume nothing",
            &[
                &"train",
                &"--data",
                d,
                &"--out",
                &r2,
                &"--config",
                &tiny,
                &"--resume",
            ],
            &["checkpoint.safetensors"],
            &[&r2.join("config.toml")],
        );
        let r3 = c.dir("existing-run");
        common::copy_tree(&run, &r3);
        c.add(
            "train over a run",
            &[&"train", &"--data", d, &"--out", &r3, &"--config", &tiny],
            &["--resume"],
            &[],
        );
        let r4 = c.dir("bad-resume-config");
        common::copy_tree(&run, &r4);
        std::fs::write(r4.join("config.toml"), "[optim]\nposition_lr_init = nan\n").expect("cfg");
        c.add(
            "resume with a bad config",
            &[&"train", &"--data", d, &"--out", &r4, &"--resume"],
            &["config.toml", "position_lr_init"],
            &[],
        );
        let r5 = c.dir("no-data-ref");
        common::copy_tree(&run, &r5);
        std::fs::remove_file(r5.join("data.txt")).expect("rm");
        let frames = r5.join("frames");
        c.add(
            "render without data record",
            &[
                &"render", &"--run", &r5, &"--out", &frames, &"--times", &"0:1:2",
            ],
            &["data.txt"],
            &[&frames],
        );
    }
    // ---- resume continues exactly what it says it continues
    {
        let resume_flags: &[(&str, &[&str], &[&str])] = &[
            (
                "resume with another motion",
                &["--motion", "deformation"],
                &["dynamics.motion", "--motion"],
            ),
            (
                "resume with another seed",
                &["--seed", "99"],
                &["seed is", "--seed"],
            ),
            (
                "resume with another protocol",
                &["--protocol", "sparse"],
                &["data.protocol", "--protocol"],
            ),
            (
                "resume with another stride",
                &["--stride", "7"],
                &["data.stride", "--stride"],
            ),
            (
                "resume with another split time",
                &["--split-time", "0.3"],
                &["data.split_time"],
            ),
            (
                "resume with another preset",
                &["--preset", "paper"],
                &["--preset paper"],
            ),
        ];
        for (name, flags, expect) in resume_flags {
            let r = c.dir("resume-flag");
            common::copy_tree(&run, &r);
            let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
                vec![&"train", &"--out", &r, &"--resume", &"--iters", &"7"];
            for f in *flags {
                args.push(f);
            }
            c.add(name, &args, expect, &[]);
        }
        for (name, overlay, expect) in [
            (
                "resume with a --config of another seed",
                "seed = 5\n",
                "seed is",
            ),
            (
                "resume with a --config of another motion",
                "[dynamics]\nmotion = \"static\"\n",
                "dynamics.motion",
            ),
            (
                "resume with a --config of another stepper",
                "[dynamics]\nmethod = \"euler\"\n",
                "dynamics.method",
            ),
            (
                "resume with a --config of another SSIM weight",
                "[loss]\nlambda_ssim = 0.5\n",
                "loss.lambda_ssim",
            ),
            (
                "resume with a --config of another anchor count",
                "[dynamics]\nanchors = 7\n",
                "dynamics.anchors",
            ),
            (
                "resume with a --config of another background",
                "[data]\nbackground = [0.0, 0.0, 0.0]\n",
                "data.background",
            ),
        ] {
            let r = c.dir("resume-overlay");
            common::copy_tree(&run, &r);
            let overlay_file = r.join("overlay.toml");
            std::fs::write(&overlay_file, overlay).expect("overlay");
            c.add(
                name,
                &[
                    &"train",
                    &"--out",
                    &r,
                    &"--resume",
                    &"--config",
                    &overlay_file,
                ],
                &[expect, "overlay.toml"],
                &[],
            );
        }
        let r = c.dir("resume-copied-checkpoint");
        common::copy_tree(&run, &r);
        let cfg_path = r.join("config.toml");
        let text = std::fs::read_to_string(&cfg_path).expect("config");
        std::fs::write(&cfg_path, text.replace("seed = 0", "seed = 11")).expect("config");
        c.add(
            "resume a checkpoint copied under another run's configuration",
            &[&"train", &"--out", &r, &"--resume"],
            &["seed is 0 in the checkpoint, 11 from"],
            &[],
        );
        let r = c.dir("resume-config-folder");
        common::copy_tree(&run, &r);
        std::fs::remove_file(r.join("config.toml")).expect("rm");
        std::fs::create_dir(r.join("config.toml")).expect("folder");
        c.add(
            "resume with config.toml a folder",
            &[&"train", &"--out", &r, &"--resume"],
            &["config.toml", "is a folder"],
            &[],
        );
        let r = c.dir("resume-data-record-folder");
        common::copy_tree(&run, &r);
        std::fs::remove_file(r.join("data.txt")).expect("rm");
        std::fs::create_dir(r.join("data.txt")).expect("folder");
        c.add(
            "resume with the data record a folder",
            &[&"train", &"--out", &r, &"--resume"],
            &["data.txt", "is a folder"],
            &[],
        );
        let r = c.dir("resume-checkpoint-folder");
        common::copy_tree(&run, &r);
        std::fs::remove_file(r.join("checkpoint.safetensors")).expect("rm");
        std::fs::create_dir(r.join("checkpoint.safetensors")).expect("folder");
        c.add(
            "eval with the checkpoint a folder",
            &[&"eval", &"--run", &r],
            &["checkpoint.safetensors", "is a folder"],
            &[],
        );
        let r = c.dir("resume-config-file");
        common::copy_tree(&run, &r);
        let wider = r.join("wider.toml");
        std::fs::write(&wider, "[field]\nwidth = 24\n").expect("cfg");
        c.add(
            "resume with a --config of another width",
            &[&"train", &"--out", &r, &"--resume", &"--config", &wider],
            &["field.width", "wider.toml"],
            &[],
        );
        for (name, key, value, expect) in [
            (
                "resume after editing the width",
                "width = ",
                "width = 24",
                "field.width",
            ),
            (
                "resume after editing a rate",
                "position_lr_init = ",
                "position_lr_init = 0.5",
                "optim.position_lr_init",
            ),
            (
                "resume after editing the motion",
                "motion = ",
                "motion = \"static\"",
                "dynamics.motion",
            ),
            (
                "resume after editing the SH degree",
                "sh_degree = ",
                "sh_degree = 0",
                "sh_degree",
            ),
        ] {
            let r = c.dir("resume-edited");
            common::copy_tree(&run, &r);
            let path = r.join("config.toml");
            let text = std::fs::read_to_string(&path).expect("config");
            let edited: String = text
                .lines()
                .map(|l| {
                    if l.starts_with(key) {
                        value.to_string()
                    } else {
                        l.to_string()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n");
            assert_ne!(edited.trim(), text.trim(), "{name}: the edit applies");
            std::fs::write(&path, edited).expect("config");
            c.add(
                name,
                &[&"train", &"--out", &r, &"--resume"],
                &[expect, "config.toml"],
                &[],
            );
        }
        // Another scene: the small scene's three frames are other training views.
        let r = c.dir("resume-other-data");
        common::copy_tree(&run, &r);
        c.add(
            "resume with --data of another scene",
            &[&"train", &"--out", &r, &"--resume", &"--data", d],
            &["other training views", "--data"],
            &[],
        );
        let r = c.dir("resume-data-record");
        common::copy_tree(&run, &r);
        std::fs::write(r.join("data.txt"), d.display().to_string()).expect("record");
        c.add(
            "resume after the data record changed",
            &[&"train", &"--out", &r, &"--resume"],
            &["other training views"],
            &[],
        );
        let r = c.dir("eval-other-data");
        common::copy_tree(&run, &r);
        let metrics = r.join("metrics-test.json");
        c.add(
            "eval against another scene",
            &[&"eval", &"--run", &r, &"--data", d],
            &["other training views"],
            &[&metrics],
        );
    }

    // ---- paths that are not regular files
    {
        let x = c.dir("not-files");
        let folder = x.join("a-folder.toml");
        std::fs::create_dir_all(&folder).expect("folder");
        let out = x.join("out");
        c.add(
            "config that is a folder",
            &[&"train", &"--data", d, &"--out", &out, &"--config", &folder],
            &["a-folder.toml", "is a folder"],
            &[&out],
        );
        c.add(
            "config that is a device",
            &[
                &"train",
                &"--data",
                d,
                &"--out",
                &out,
                &"--config",
                &"/dev/zero",
            ],
            &["/dev/zero", "is a device"],
            &[&out],
        );
        c.add(
            "verify a device",
            &[&"verify", &"/dev/zero"],
            &["/dev/zero", "is a device"],
            &[],
        );
        c.add(
            "verify a folder",
            &[&"verify", &folder],
            &["is a folder"],
            &[],
        );
        c.add(
            "data that is a file",
            &[
                &"train",
                &"--data",
                &tiny,
                &"--out",
                &out,
                &"--config",
                &tiny,
            ],
            &["this is a file", "dataset is a folder"],
            &[&out],
        );
        c.add(
            "eval with data that is a file",
            &[&"eval", &"--run", &run, &"--data", &tiny],
            &["this is a file"],
            &[],
        );
        let (la, lb) = (x.join("loop-a.toml"), x.join("loop-b.toml"));
        std::os::unix::fs::symlink(&lb, &la).expect("link");
        std::os::unix::fs::symlink(&la, &lb).expect("link");
        c.add(
            "config that is a symlink loop",
            &[&"train", &"--data", d, &"--out", &out, &"--config", &la],
            &["loop-a.toml", "loop of symbolic links"],
            &[&out],
        );
        c.add(
            "verify a symlink loop",
            &[&"verify", &la],
            &["loop-a.toml", "loop of symbolic links"],
            &[],
        );
        let fifo = x.join("pipe.toml");
        if std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success())
        {
            c.add(
                "config that is a FIFO",
                &[&"train", &"--data", d, &"--out", &out, &"--config", &fifo],
                &["pipe.toml", "FIFO"],
                &[&out],
            );
            c.add(
                "verify a FIFO",
                &[&"verify", &fifo],
                &["pipe.toml", "FIFO"],
                &[],
            );
        }
        c.add(
            "export onto a folder",
            &[
                &"export", &"--run", &run, &"--time", &"0.5", &"--out", &folder,
            ],
            &["a-folder.toml", "it is a folder"],
            &[],
        );
        c.add(
            "export onto a device",
            &[
                &"export",
                &"--run",
                &run,
                &"--time",
                &"0.5",
                &"--out",
                &"/dev/null",
            ],
            &["/dev/null", "a device"],
            &[],
        );
        if fifo.exists() {
            c.add(
                "export onto a FIFO",
                &[
                    &"export", &"--run", &run, &"--time", &"0.5", &"--out", &fifo,
                ],
                &["pipe.toml", "FIFO"],
                &[],
            );
        }
        let to_folder = x.join("to-folder.ply");
        std::os::unix::fs::symlink(&folder, &to_folder).expect("link");
        c.add(
            "export onto a link to a folder",
            &[
                &"export", &"--run", &run, &"--time", &"0.5", &"--out", &to_folder,
            ],
            &["to-folder.ply", "which is a folder"],
            &[],
        );
        let stale = c.dir("stale-frames");
        std::fs::write(stale.join("frame_0000.png"), b"old").expect("frame");
        std::fs::write(stale.join("frame_0001.png"), b"old").expect("frame");
        c.add(
            "render over an earlier render",
            &[
                &"render", &"--run", &run, &"--out", &stale, &"--times", &"0:1:1",
            ],
            &["earlier sequence", "--force"],
            &[&stale.join("frames.json")],
        );
        c.add(
            "inject over an earlier render",
            &[
                &"inject",
                &"--run",
                &run,
                &"--out",
                &stale,
                &"--times",
                &"0:1:1",
                &"--mask",
                &"sphere:0,0,0,1",
                &"--field",
                &"translate:0,0,1",
            ],
            &["earlier sequence", "--force"],
            &[&stale.join("frames.json")],
        );
        let stale_ply = c.dir("stale-ply");
        std::fs::write(stale_ply.join("frame_0007.ply"), b"old").expect("ply");
        c.add(
            "export a sequence over an earlier one",
            &[
                &"export", &"--run", &run, &"--times", &"0:1:2", &"--out", &stale_ply,
            ],
            &["earlier sequence", "--force"],
            &[
                &stale_ply.join("sequence.json"),
                &stale_ply.join("frame_0000.ply"),
            ],
        );
        c.add(
            "export --force without --times",
            &[
                &"export",
                &"--run",
                &run,
                &"--time",
                &"0.5",
                &"--out",
                &x.join("one.ply"),
                &"--force",
            ],
            &["--times"],
            &[&x.join("one.ply")],
        );
        let (ea, eb) = (x.join("loop-a.ply"), x.join("loop-b.ply"));
        std::os::unix::fs::symlink(&eb, &ea).expect("link");
        std::os::unix::fs::symlink(&ea, &eb).expect("link");
        c.add(
            "export onto a symlink loop",
            &[&"export", &"--run", &run, &"--time", &"0.5", &"--out", &ea],
            &["loop-a.ply", "loop of symbolic links"],
            &[],
        );
        let a_file = x.join("a-file");
        std::fs::write(&a_file, b"x").expect("file");
        c.add(
            "render into a file",
            &[
                &"render", &"--run", &run, &"--out", &a_file, &"--times", &"0:1:1",
            ],
            &["a-file"],
            &[],
        );
        c.add(
            "train into a file",
            &[
                &"train",
                &"--data",
                d,
                &"--out",
                &a_file,
                &"--config",
                &tiny,
            ],
            &["a-file", "this is a regular file", "is a folder"],
            &[],
        );
        c.add(
            "study into a file",
            &[&"study", &"--out", &a_file, &"--iters", &"1"],
            &["a-file", "this is a regular file"],
            &[],
        );
        c.add(
            "export a sequence into a file",
            &[
                &"export", &"--run", &run, &"--times", &"0:1:2", &"--out", &a_file,
            ],
            &["a-file"],
            &[],
        );
        c.add(
            "study with data that is a file",
            &[
                &"study",
                &"--data",
                &tiny,
                &"--out",
                &x.join("study"),
                &"--iters",
                &"1",
            ],
            &["this is a file"],
            &[&x.join("study").join("study.json")],
        );
        c.add(
            "render with data that is a file",
            &[
                &"render",
                &"--run",
                &run,
                &"--data",
                &tiny,
                &"--out",
                &x.join("r"),
                &"--times",
                &"0:1:1",
            ],
            &["this is a file"],
            &[&x.join("r")],
        );
        for (name, file) in [
            ("point cloud that is a folder", "points3d.ply"),
            ("test transforms that is a folder", "transforms_test.json"),
        ] {
            let s = c.dir("scene-node");
            small_scene(&s);
            let p = s.join(file);
            let _ = std::fs::remove_file(&p);
            std::fs::create_dir_all(&p).expect("folder");
            let o = s.join("run");
            c.add(
                name,
                &[&"train", &"--data", &s, &"--out", &o, &"--config", &tiny],
                &[file, "folder"],
                &[&o],
            );
        }
        for (name, file) in [
            ("poses that is a folder", "poses_bounds.npy"),
            ("frame times that is a folder", "times.txt"),
        ] {
            let s = c.dir("mv-node");
            mv_scene(&s);
            let p = s.join(file);
            let _ = std::fs::remove_file(&p);
            std::fs::create_dir_all(&p).expect("folder");
            let o = s.join("run");
            c.add(
                name,
                &[&"train", &"--data", &s, &"--out", &o, &"--config", &tiny],
                &[file, "folder"],
                &[&o],
            );
        }
        if fifo.exists() {
            let s = c.dir("transforms-fifo");
            small_scene(&s);
            let p = s.join("transforms_train.json");
            std::fs::remove_file(&p).expect("rm");
            let made = std::process::Command::new("mkfifo").arg(&p).status();
            if made.is_ok_and(|m| m.success()) {
                c.add(
                    "transforms file that is a FIFO",
                    &[&"train", &"--data", &s, &"--out", &out, &"--config", &tiny],
                    &["transforms_train.json", "FIFO"],
                    &[&out],
                );
            }
        }
        let latin1 = x.join("latin1.toml");
        std::fs::write(&latin1, b"# caf\xe9\nseed = 1\n").expect("write");
        c.add(
            "config that is not UTF-8",
            &[&"train", &"--data", d, &"--out", &out, &"--config", &latin1],
            &["latin1.toml", "not UTF-8", "offset 5"],
            &[&out],
        );
        let latin1_json = x.join("latin1.json");
        std::fs::write(&latin1_json, b"{\"caf\xe9\": 1}").expect("write");
        c.add(
            "verify a file that is not UTF-8",
            &[&"verify", &latin1_json],
            &["latin1.json", "not UTF-8"],
            &[],
        );
        let s = c.dir("transforms-latin1");
        small_scene(&s);
        let t = s.join("transforms_train.json");
        let mut bytes = std::fs::read(&t).expect("json");
        bytes.splice(1..1, [b' ', 0xff, b' ']);
        std::fs::write(&t, bytes).expect("json");
        c.add(
            "transforms file that is not UTF-8",
            &[&"train", &"--data", &s, &"--out", &out, &"--config", &tiny],
            &["transforms_train.json", "not UTF-8"],
            &[&out],
        );
        let s = c.dir("times-latin1");
        mv_scene(&s);
        std::fs::write(s.join("times.txt"), b"0.0\n\xff\n").expect("times");
        c.add(
            "frame times that are not UTF-8",
            &[&"train", &"--data", &s, &"--out", &out, &"--config", &tiny],
            &["times.txt", "not UTF-8"],
            &[&out],
        );
        let dangling = x.join("dangling.ply");
        std::os::unix::fs::symlink(x.join("no-folder").join("x.ply"), &dangling).expect("link");
        c.add(
            "export through a link into a missing folder",
            &[
                &"export", &"--run", &run, &"--time", &"0.5", &"--out", &dangling,
            ],
            &["dangling.ply"],
            &[],
        );
        let link_to_file = x.join("link-to-file");
        std::os::unix::fs::symlink(&a_file, &link_to_file).expect("link");
        c.add(
            "render into a link to a file",
            &[
                &"render",
                &"--run",
                &run,
                &"--out",
                &link_to_file,
                &"--times",
                &"0:1:1",
            ],
            &["link-to-file"],
            &[],
        );
        for (name, seeds, motions) in [
            (
                "study of one motion beyond the run bound",
                "10001",
                "velocity",
            ),
            (
                "study of three motions beyond the run bound",
                "3334",
                "velocity,deformation,static",
            ),
        ] {
            c.add(
                name,
                &[
                    &"study",
                    &"--seeds",
                    &seeds,
                    &"--motions",
                    &motions,
                    &"--out",
                    &x.join("st"),
                ],
                &["at most 10000"],
                &[&x.join("st")],
            );
        }
        let huge = x.join("huge.toml");
        std::fs::write(&huge, vec![b'#'; (1 << 20) + 1]).expect("huge");
        c.add(
            "config larger than a configuration can be",
            &[&"train", &"--data", d, &"--out", &out, &"--config", &huge],
            &["huge.toml", "at most 1048576 bytes"],
            &[&out],
        );
        let s = c.dir("transforms-folder");
        small_scene(&s);
        std::fs::remove_file(s.join("transforms_train.json")).expect("rm");
        std::fs::create_dir_all(s.join("transforms_train.json")).expect("folder");
        c.add(
            "transforms file that is a folder",
            &[&"train", &"--data", &s, &"--out", &out, &"--config", &tiny],
            &["transforms_train.json", "is a folder"],
            &[&out],
        );
        let s = c.dir("frame-folder");
        small_scene(&s);
        let frame = s.join("train").join("r_000.png");
        if frame.is_file() {
            std::fs::remove_file(&frame).expect("rm");
            std::fs::create_dir_all(&frame).expect("folder");
            c.add(
                "frame that is a folder",
                &[&"train", &"--data", &s, &"--out", &out, &"--config", &tiny],
                &["r_000.png", "folder"],
                &[&out],
            );
        }
    }
    {
        let x = c.dir("export-dir");
        let into_dir = x.join("missing-folder").join("x.ply");
        c.add(
            "export into a missing folder",
            &[
                &"export", &"--run", &run, &"--time", &"0.5", &"--out", &into_dir,
            ],
            &["x.ply"],
            &[&into_dir],
        );
    }

    // ---- reference files for verify
    let v = c.dir("verify");
    let files: &[(&str, &str, &str)] = &[
        ("verify garbage", "a.json", "not json at all"),
        ("verify unknown kind", "b.json", "{\"hello\": 1}"),
        ("verify empty", "c.json", ""),
        (
            "verify ode malformed",
            "d.json",
            "{\"case\": {\"runs\": [{\"results\": 3}]}}",
        ),
    ];
    for (name, file, text) in files {
        let p = v.join(file);
        std::fs::write(&p, text).expect("write");
        c.add(name, &[&"verify", &p], &[file], &[]);
    }
    let missing = v.join("nothing.json");
    c.add(
        "verify missing file",
        &[&"verify", &missing],
        &["nothing.json"],
        &[],
    );
}

#[test]
fn every_bad_input_gets_one_clear_error_and_leaves_nothing_behind() {
    let root = common::scratch("hostile");
    let mut cases = Cases::new(root.clone());
    build(&mut cases);
    let n = cases.list.len();
    assert!(
        n >= 250,
        "the suite has {n} cases; it should have at least 250"
    );
    let failures: Vec<String> = std::thread::scope(|s| {
        let chunks: Vec<&[Case]> = cases.list.chunks(n.div_ceil(2)).collect();
        let handles: Vec<_> = chunks
            .into_iter()
            .map(|chunk| {
                s.spawn(move || {
                    chunk
                        .iter()
                        .filter_map(|c| check(c).err().map(|e| format!("{}: {e}", c.name)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("worker"))
            .collect()
    });
    assert!(
        failures.is_empty(),
        "{} of {n} bad inputs broke the contract:\n{}",
        failures.len(),
        failures.join("\n")
    );
    std::fs::remove_dir_all(root).ok();
}
