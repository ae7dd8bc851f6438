//! Times a trained model cannot be evaluated at in bounded work (non-finite, or far outside
//! its trained range) are refused with a message by export, render and inject, before any
//! output is written; times within the bound (negative and beyond 1 too) work. `eval` refuses
//! a time range without frames and keeps a restricted evaluation apart from the whole one.

use evogs::data::SplitName;
use evogs_cli::app::Silent;
use evogs_cli::app::evaluate::{evaluate_run, parse_range};
use evogs_cli::app::export::export;
use evogs_cli::app::paths::shipped_scene;
use evogs_cli::app::render::{CameraPath, RenderArgs, render_sequence};

use crate::common;

#[test]
fn export_and_render_refuse_times_out_of_reach() {
    let dir = common::scratch("bad-times");
    let run = common::tiny_run(&dir);
    for t in [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e308,
        -1e6,
        1000.0,
    ] {
        let out = dir.join("x.ply");
        let e = export(&run, t, &out).expect_err("refused").to_string();
        assert!(
            e.contains("--time") && e.contains("outside"),
            "t = {t}: {e}"
        );
        assert!(!out.exists(), "nothing written for t = {t}");
    }
    for t in [-0.5, 0.5, 1.5] {
        export(&run, t, &dir.join("ok.ply")).unwrap_or_else(|e| panic!("t = {t}: {e}"));
    }
    let render = |times: (f64, f64, usize)| {
        render_sequence(
            &RenderArgs {
                run: run.clone(),
                out: dir.join("frames"),
                times,
                camera: CameraPath::Orbit,
                gif: false,
                data: Some(shipped_scene()),
                format: None,
                force: false,
            },
            None,
            &mut Silent,
        )
    };
    let e = render((-1e6, 0.0, 2)).expect_err("refused").to_string();
    assert!(e.contains("--times") && e.contains("outside"), "{e}");
    assert!(
        !dir.join("frames").exists(),
        "no output folder for refused times"
    );
    assert_eq!(
        render((-0.25, 1.25, 2)).expect("within reach").count,
        2,
        "frames"
    );
    // eval: a range that selects nothing is an error, and a restricted evaluation goes to a
    // file of its own that records the range, next to the whole split's.
    for bad in ["nan:1", "0:inf", "1:0", "0.5"] {
        assert!(parse_range(bad).is_err(), "`{bad}` refused");
    }
    let (whole, whole_path) =
        evaluate_run(&run, SplitName::Test, None, None, None, &mut Silent).expect("whole split");
    let before = std::fs::read(&whole_path).expect("metrics-test.json");
    let e = evaluate_run(
        &run,
        SplitName::Test,
        Some((5.0, 6.0)),
        None,
        None,
        &mut Silent,
    )
    .expect_err("no frame in 5:6")
    .to_string();
    assert!(e.contains("selects none of the 10 `test` frames"), "{e}");
    let (part, part_path) = evaluate_run(
        &run,
        SplitName::Test,
        Some((0.5, 1.0)),
        None,
        None,
        &mut Silent,
    )
    .expect("part");
    assert!(
        part.frames.len() < whole.frames.len() && !part.frames.is_empty(),
        "a subset"
    );
    assert_eq!(part.time_range, Some([0.5, 1.0]), "the range is recorded");
    assert_ne!(part_path, whole_path, "a file of its own");
    assert_eq!(
        std::fs::read(&whole_path).expect("kept"),
        before,
        "the whole split's file is kept"
    );
    std::fs::remove_dir_all(&dir).ok();
}
