//! The dataset parsers, each fed the same arbitrary bytes: a D-NeRF `transforms_*.json`
//! (`parse_transforms`, training and test splits), a multi-view `poses_bounds.npy`
//! (`parse_poses`, through the `.npy` reader) and a multi-view times file
//! (`parse_frame_times`).
//!
//! Properties: none panics, whatever the bytes; what each accepts is usable: a field of view
//! in (0, π), at least one frame, finite matrices within ±1e6, finite times and, for the
//! training split, times in [0, 1]; poses with finite entries and positive focal lengths;
//! frame times increasing in [0, 1], as many as asked for.
#![no_main]

use evogs::data::SplitName;
use evogs::data::dnerf::parse_transforms;
use evogs::data::n3dv::{parse_frame_times, parse_poses};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(poses) = parse_poses(data) {
        assert!(!poses.is_empty());
        for p in &poses {
            assert!(p.focal() > 0.0 && p.width() >= 1.0 && p.height() >= 1.0);
            assert!(p.c2w_opengl().iter().flatten().all(|v| v.is_finite()));
        }
    }
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for split in [SplitName::Train, SplitName::Test] {
        if let Ok(f) = parse_transforms(text, split) {
            assert!(f.camera_angle_x > 0.0 && f.camera_angle_x < std::f64::consts::PI);
            assert!(!f.frames.is_empty());
            for fr in &f.frames {
                assert!(fr.transform_matrix.iter().flatten().all(|v| v.is_finite() && v.abs() <= 1e6));
                assert!(fr.time.is_finite());
                if split == SplitName::Train {
                    assert!((0.0..=1.0).contains(&fr.time));
                }
            }
        }
    }
    let count = usize::from(data.first().copied().unwrap_or(0) % 8);
    if let Ok(times) = parse_frame_times(text, count) {
        assert_eq!(times.len(), count);
        assert!(times.iter().all(|t| (0.0..=1.0).contains(t)));
        assert!(times.windows(2).all(|w| w[0] < w[1]));
    }
});
