//! The command-line specifications, each fed the same arbitrary text: time ranges
//! (`parse_range`, `A:B`), frame specifications (`parse_times`, `A:B:N`), inject masks and
//! fields (`parse_mask`, `parse_field`), study protocols (`StudyProtocol::parse_list`) and
//! motions (`parse_motions`).
//!
//! Properties: none panics; what each accepts is usable: finite times with `A ≤ B`, `N ≥ 1`;
//! masks with finite `f32` numbers, a positive radius or a non-empty box and a positive soft
//! width; fields with finite `f32` numbers; protocols and motions non-empty, without
//! repeats, and protocols that print and parse back to themselves.
#![no_main]

use evogs_cli::app::evaluate::parse_range;
use evogs_cli::app::inject::{FieldSpec, parse_field, parse_mask};
use evogs_cli::app::render::parse_times;
use evogs_cli::app::study::{StudyProtocol, parse_motions};
use evogs_math::Vec3;
use evogs_ode::algebra::{Edge, Mask};
use libfuzzer_sys::fuzz_target;

fn finite3<T: evogs_math::Real>(v: Vec3<T>) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

fuzz_target!(|data: &[u8]| {
    let Ok(s) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok((a, b)) = parse_range(s) {
        assert!(
            a.is_finite() && b.is_finite() && a <= b,
            "range `{s}`: {a}..{b}"
        );
    }
    if let Ok((a, b, n)) = parse_times(s) {
        assert!(
            a.is_finite() && b.is_finite() && n >= 1,
            "times `{s}`: {a}, {b}, {n}"
        );
    }
    if let Ok(m) = parse_mask(s) {
        let edge = match &m {
            Mask::Sphere {
                center,
                radius,
                edge,
            } => {
                assert!(
                    finite3(*center) && radius.is_finite() && *radius > 0.0,
                    "sphere `{s}`"
                );
                edge
            }
            Mask::Box { min, max, edge } => {
                assert!(finite3(*min) && finite3(*max), "box `{s}` finite");
                assert!(
                    min.x < max.x && min.y < max.y && min.z < max.z,
                    "box `{s}` non-empty"
                );
                edge
            }
            other => panic!("`{s}` parsed as an unexpected mask {other:?}"),
        };
        if let Edge::Soft { width } = edge {
            assert!(width.is_finite() && *width > 0.0, "soft width of `{s}`");
        }
    }
    if let Ok(f) = parse_field(s) {
        let in_f32 = |v: Vec3<f64>| finite3(v) && finite3(v.cast::<f32>());
        match f {
            FieldSpec::Rotate { omega, center } => {
                assert!(in_f32(omega) && center.is_none_or(in_f32), "rotation `{s}`");
            }
            FieldSpec::Translate(u) => assert!(in_f32(u), "translation `{s}`"),
        }
    }
    if let Ok(list) = StudyProtocol::parse_list(s) {
        assert!(!list.is_empty(), "protocols `{s}`");
        let printed: Vec<String> = list.iter().map(ToString::to_string).collect();
        let back = StudyProtocol::parse_list(&printed.join(",")).expect("printed list parses");
        assert_eq!(back, list, "protocols `{s}` print and parse back");
    }
    if let Ok(motions) = parse_motions(s) {
        assert!(!motions.is_empty(), "motions `{s}`");
        for (i, m) in motions.iter().enumerate() {
            assert!(!motions[..i].contains(m), "motion repeated in `{s}`");
        }
    }
});
