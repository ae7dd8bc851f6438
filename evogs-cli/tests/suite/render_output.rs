//! `evogs render` writes each frame as it comes and streams the GIF: a finished render leaves
//! exactly its frames and GIF (no temporary files); an interrupt stops after the current
//! frame with a message, keeping the finished frames and writing no GIF; an orbit of any
//! length costs nothing to set up (its poses are computed per frame).

use crate::common;

use evogs::run::checkpoint;
use evogs_cli::app::export::{SEQUENCE_FILE, Sequence, export, export_sequence};
use evogs_cli::app::frame_writer::{FrameIndex, INDEX_FILE};
use evogs_cli::app::interrupt;
use evogs_cli::app::paths::shipped_scene;
use evogs_cli::app::render::{CameraPath, FrameCameras, RenderArgs, path_cameras, render_sequence};
use evogs_cli::app::{Notes, Reporter};
use std::path::{Path, PathBuf};

/// Asks for an interrupt once `at` frames are done (what Ctrl-C does mid-render).
struct InterruptAt(u64);

impl Reporter for InterruptAt {
    fn start(&mut self, _: &str, _: u64) {}
    fn progress(&mut self, done: u64, _: &str) {
        if done == self.0 {
            interrupt::request_on_this_thread();
        }
    }
    fn finish(&mut self) {}
    fn info(&mut self, _: &str) {}
}

/// The folder's files, but for the writer's lock file (`.evogs.lock`, which stays: the
/// lock is the operating system's and goes with the process).
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n != evogs_cli::app::lock::LOCK_FILE)
        .collect();
    v.sort();
    v
}

#[test]
fn frames_stream_to_disk_and_an_interrupt_keeps_what_is_finished() {
    let dir = common::scratch("render-output");
    let run = common::tiny_run(&dir);
    let args = |out: PathBuf, n: usize| RenderArgs {
        run: run.clone(),
        out,
        times: (0.0, 1.0, n),
        camera: CameraPath::Orbit,
        gif: true,
        data: Some(shipped_scene()),
        format: None,
        force: false,
    };

    let full = dir.join("full");
    let o =
        render_sequence(&args(full.clone(), 4), None, &mut InterruptAt(0)).expect("a whole render");
    assert_eq!((o.count, o.gif.clone()), (4, Some(full.join("render.gif"))));
    assert_eq!(
        listing(&full),
        [
            "frame_0000.png",
            "frame_0001.png",
            "frame_0002.png",
            "frame_0003.png",
            "frames.json",
            "render.gif"
        ],
        "exactly the frames, the index and the GIF, no temporary files"
    );
    let index: FrameIndex =
        serde_json::from_str(&std::fs::read_to_string(full.join(INDEX_FILE)).expect("index"))
            .expect("json");
    assert_eq!(index.files.len(), 4);
    assert_eq!(index.times, [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]);
    assert_eq!(index.gif.as_deref(), Some("render.gif"));

    let gif = std::fs::read(full.join("render.gif")).expect("gif");
    assert!(
        gif.starts_with(b"GIF89a") && gif.ends_with(&[0x3b]),
        "a complete GIF"
    );

    // A second, shorter render into the same folder: refused, then with --force the folder
    // holds its frames alone (no stale frame_0002/0003 of the first).
    let e = render_sequence(&args(full.clone(), 2), None, &mut InterruptAt(0))
        .expect_err("an earlier sequence")
        .to_string();
    assert!(
        e.contains("earlier sequence") && e.contains("--force"),
        "{e}"
    );
    assert_eq!(listing(&full).len(), 6, "nothing touched by the refusal");
    let forced = RenderArgs {
        force: true,
        gif: false,
        ..args(full.clone(), 2)
    };
    render_sequence(&forced, None, &mut InterruptAt(0)).expect("replaced");
    assert_eq!(
        listing(&full),
        ["frame_0000.png", "frame_0001.png", "frames.json"],
        "only the new sequence"
    );

    let cut = dir.join("cut");
    let e = render_sequence(&args(cut.clone(), 5), None, &mut InterruptAt(2))
        .expect_err("interrupted")
        .to_string();
    assert!(
        e.contains("interrupted: 2 of 5 frames") && e.contains("no GIF"),
        "{e}"
    );
    assert!(
        !interrupt::requested(),
        "the request is withdrawn once honoured"
    );
    assert_eq!(
        listing(&cut),
        ["frame_0000.png", "frame_0001.png"],
        "the finished frames, no partial GIF, index or temporary file"
    );

    // An interrupt during an evaluation stops it before the next frame, writing nothing.
    let e = evogs_cli::app::evaluate::evaluate_run(
        &run,
        evogs::data::SplitName::Test,
        None,
        None,
        None,
        &mut InterruptAt(1),
    )
    .expect_err("interrupted")
    .to_string();
    assert!(e.starts_with("interrupted after 1 of "), "{e}");
    assert!(!interrupt::requested(), "the request is withdrawn");
    assert!(
        !run.join("metrics-test.json").exists(),
        "no metrics written"
    );

    // An orbit for a hundred million frames is a formula, not a list.
    let l = checkpoint::load_model(&run.join("checkpoint.safetensors")).expect("model");
    let ds = evogs_cli::app::load::load_dataset(&shipped_scene(), &l.cfg, false).expect("data");
    let cams = path_cameras(&CameraPath::Orbit, &ds, &l.model, 100_000_000).expect("orbit");
    assert!(matches!(cams, FrameCameras::Orbit(_)));
    let (c0, c_last) = (
        cams.get(0).expect("pose"),
        cams.get(99_999_999).expect("pose"),
    );
    assert!(c0 != c_last, "distinct poses along the orbit");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn an_exported_sequence_matches_single_exports_and_lists_its_files() {
    let dir = common::scratch("export-seq");
    let run = common::tiny_run(&dir);
    let out = dir.join("seq");
    let seq = export_sequence(&run, (-0.25, 1.25, 3), &out, false, &mut InterruptAt(0))
        .expect("sequence");
    assert_eq!(
        seq.files,
        ["frame_0000.ply", "frame_0001.ply", "frame_0002.ply"]
    );
    assert_eq!(seq.times, [-0.25, 0.5, 1.25]);
    let index: Sequence =
        serde_json::from_str(&std::fs::read_to_string(out.join(SEQUENCE_FILE)).expect("index"))
            .expect("json");
    assert_eq!(index, seq, "sequence.json lists the files and times");
    for (file, &t) in seq.files.iter().zip(&seq.times) {
        let single = dir.join("single.ply");
        let n = export(&run, t, &single).expect("single export");
        assert_eq!(n, seq.gaussians);
        assert_eq!(
            std::fs::read(out.join(file)).expect("frame"),
            std::fs::read(&single).expect("single"),
            "{file}: the same bytes as `export --time {t}`"
        );
    }
    let cut = dir.join("cut");
    let again = export_sequence(&run, (0.0, 1.0, 2), &out, false, &mut InterruptAt(0))
        .expect_err("an earlier sequence")
        .to_string();
    assert!(again.contains("earlier sequence"), "{again}");
    export_sequence(&run, (0.0, 1.0, 2), &out, true, &mut InterruptAt(0)).expect("replaced");
    assert!(
        !out.join("frame_0002.ply").exists(),
        "no stale file of the longer sequence"
    );
    let e = export_sequence(&run, (0.0, 1.0, 4), &cut, false, &mut InterruptAt(1))
        .expect_err("interrupted")
        .to_string();
    assert!(
        e.contains("interrupted: 1 of 4") && e.contains(SEQUENCE_FILE),
        "{e}"
    );
    assert!(
        !cut.join(SEQUENCE_FILE).exists(),
        "no index for an incomplete sequence"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn an_injection_mask_that_holds_no_gaussian_is_noted() {
    use evogs_cli::app::inject::{InjectArgs, inject, parse_field, parse_mask};
    let dir = common::scratch("inject-note");
    let run = common::tiny_run(&dir);
    let args = |mask: &str, out: &str| InjectArgs {
        run: run.clone(),
        out: dir.join(out),
        mask: parse_mask(mask).expect("mask"),
        field: parse_field("translate:0,0,1").expect("field"),
        times: (0.0, 1.0, 2),
        camera: CameraPath::Orbit,
        gif: false,
        data: Some(shipped_scene()),
        format: None,
        force: false,
    };
    let mut far = Notes::default();
    inject(&args("sphere:100,100,100,0.5", "far"), &mut far).expect("frames");
    assert!(
        far.0.iter().any(|n| n.contains("holds no Gaussian")),
        "{:?}",
        far.0
    );
    let mut near = Notes::default();
    inject(&args("sphere:0,0,0,100", "near"), &mut near).expect("frames");
    assert!(
        !near.0.iter().any(|n| n.contains("holds no Gaussian")),
        "{:?}",
        near.0
    );
    std::fs::remove_dir_all(dir).ok();
}
