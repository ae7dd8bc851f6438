//! The pinhole camera: D-NeRF (OpenGL camera-to-world) conversion, look-at, view matrices,
//! validation errors (each checked entry alone, and the rigidity tolerance at its edge).

use evogs_math::{Mat3, Vec3};
use evogs_splat::{CameraError, CameraGrad, PinholeCamera};

/// Frame `r_000` of the project's `toys-mini/transforms_train.json` (D-NeRF format).
const C2W: [[f64; 4]; 4] = [
    [
        0.9649090365464632,
        -0.18419193761510935,
        0.18714668393687264,
        0.7485867357474906,
    ],
    [
        0.2625843696623545,
        0.6768432762862256,
        -0.6877009729200272,
        -2.7508038916801087,
    ],
    [
        -0.0,
        0.7127106772482923,
        0.7014581174498449,
        2.8058324697993795,
    ],
    [0.0, 0.0, 0.0, 1.0],
];
const FOV_X: f64 = 0.8726646259971648;
/// The identity view matrix: a camera at the origin looking along +z.
const ID: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];
/// Intrinsics of a 64 × 48 image.
const K: [[f64; 3]; 3] = [[50.0, 0.0, 32.0], [0.0, 50.0, 24.0], [0.0, 0.0, 1.0]];

#[test]
fn dnerf_conversion_flips_y_and_z_then_inverts() {
    let cam = PinholeCamera::<f64>::from_dnerf(C2W, FOV_X, 200, 200).expect("valid frame");
    let col = |j: usize| Vec3::new(C2W[0][j], C2W[1][j], C2W[2][j]);
    // The centre is the translation column.
    assert!((cam.center() - col(3)).norm() < 1e-12, "centre");
    // Camera axes in the world: x = col0, y (down) = −col1, z (forward) = −col2.
    for (axis, want) in [(0, col(0)), (1, -col(1)), (2, -col(2))] {
        assert!(
            (cam.rotation.row(axis) - want).norm() < 1e-12,
            "axis {axis}"
        );
    }
    // This rig looks at the origin: it projects to the principal point, in front.
    let p = cam.world_to_camera(Vec3::zero());
    assert!(
        p.z > 3.0 && (p.x / p.z).abs() < 1e-6 && (p.y / p.z).abs() < 1e-6,
        "origin on the optical axis: {p:?}"
    );
    // fx = W / (2 tan(fov/2)), principal point at the centre, gsplat clip planes.
    assert!(
        (cam.fx - 100.0 / (0.5 * FOV_X).tan()).abs() < 1e-9 && (cam.fx - cam.fy).abs() < 1e-15,
        "focal"
    );
    assert!(
        (cam.cx - 100.0).abs() < 1e-15
            && (cam.cy - 100.0).abs() < 1e-15
            && (cam.near - 0.01).abs() < 1e-15
            && (cam.far - 1e10).abs() < 1.0,
        "centre and clip"
    );
    // World +z (up in Blender) points up in the image (negative v) for this camera.
    let up = cam.world_to_camera(Vec3::new(0.0, 0.0, 0.5));
    assert!(up.y < 0.0, "world up is image up");
}

#[test]
fn dnerf_conversion_agrees_with_look_at() {
    let eye = Vec3::new(1.5, -2.0, 2.5);
    let up = Vec3::new(0.0, 0.0, 1.0);
    // OpenGL c2w of a camera at `eye` looking at the origin: x right, y up, z backward.
    let back = eye * (1.0 / eye.norm());
    let right = up.cross(back) * (1.0 / up.cross(back).norm());
    let cam_up = back.cross(right);
    let c2w = [
        [right.x, cam_up.x, back.x, eye.x],
        [right.y, cam_up.y, back.y, eye.y],
        [right.z, cam_up.z, back.z, eye.z],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let a = PinholeCamera::<f64>::from_dnerf(c2w, 0.7, 64, 48).expect("dnerf");
    let b = PinholeCamera::<f64>::look_at(eye, Vec3::zero(), up, 0.7, 64, 48).expect("look_at");
    assert!((a.rotation - b.rotation).max_abs() < 1e-14, "rotation");
    assert!(
        (a.translation - b.translation).norm() < 1e-14,
        "translation"
    );
    assert!(
        (a.fx - b.fx).abs() < 1e-12 && (a.cy - 24.0).abs() < 1e-15,
        "intrinsics"
    );
}

#[test]
fn view_matrix_round_trip_and_cast() {
    let cam = PinholeCamera::<f64>::from_dnerf(C2W, FOV_X, 200, 160).expect("valid");
    let k = [
        [cam.fx, 0.0, cam.cx],
        [0.0, cam.fy, cam.cy],
        [0.0, 0.0, 1.0],
    ];
    let back =
        PinholeCamera::from_viewmat(cam.viewmat(), k, 200, 160, cam.near, cam.far).expect("rigid");
    assert_eq!(back, cam, "viewmat round trip");
    let c32 = cam.cast::<f32>();
    assert!(
        (f64::from(c32.fx) - cam.fx).abs() < 1e-4 && c32.width == 200,
        "cast"
    );
}

#[test]
fn invalid_cameras_are_typed_errors() {
    let bad = |c2w: [[f64; 4]; 4], fov: f64, w: usize| {
        PinholeCamera::<f64>::from_dnerf(c2w, fov, w, 100).err()
    };
    let mut nan = C2W;
    nan[1][2] = f64::NAN;
    assert_eq!(bad(nan, FOV_X, 100), Some(CameraError::NonFinite));
    let mut scaled = C2W;
    for row in scaled.iter_mut().take(3) {
        row[0] *= 1.1;
    }
    assert_eq!(bad(scaled, FOV_X, 100), Some(CameraError::NotRigid));
    let mut mirrored = C2W;
    for row in mirrored.iter_mut().take(3) {
        row[0] = -row[0];
    }
    assert_eq!(
        bad(mirrored, FOV_X, 100),
        Some(CameraError::NotRigid),
        "det −1"
    );
    let mut bottom = C2W;
    bottom[3][0] = 0.5;
    assert_eq!(bad(bottom, FOV_X, 100), Some(CameraError::NotRigid));
    assert_eq!(bad(C2W, 0.0, 100), Some(CameraError::BadIntrinsics));
    assert_eq!(bad(C2W, 3.2, 100), Some(CameraError::BadIntrinsics));
    assert_eq!(bad(C2W, f64::NAN, 100), Some(CameraError::NonFinite));
    assert_eq!(bad(C2W, FOV_X, 0), Some(CameraError::EmptyImage));
    let id = ID;
    let k = K;
    assert_eq!(
        PinholeCamera::from_viewmat(id, k, 64, 48, 1.0, 0.5).err(),
        Some(CameraError::BadClipRange)
    );
    let k0 = [[0.0, 0.0, 32.0], [0.0, 50.0, 24.0], [0.0, 0.0, 1.0]];
    assert_eq!(
        PinholeCamera::from_viewmat(id, k0, 64, 48, 0.01, 10.0).err(),
        Some(CameraError::BadIntrinsics)
    );
    let z = Vec3::zero();
    let up = Vec3::new(0.0, 1.0, 0.0);
    assert_eq!(
        PinholeCamera::<f64>::look_at(z, z, up, 0.7, 8, 8).err(),
        Some(CameraError::DegenerateLookAt)
    );
    assert_eq!(
        PinholeCamera::<f64>::look_at(Vec3::new(0.0, 3.0, 0.0), z, up, 0.7, 8, 8).err(),
        Some(CameraError::DegenerateLookAt),
        "up parallel to the view"
    );
    assert!(!format!("{}", CameraError::NotRigid).is_empty(), "Display");
}

#[test]
fn validation_checks_every_entry_and_is_inclusive_at_the_tolerance() {
    // The documented rigidity tolerance: a deviation of exactly 1e-4 is accepted, more is not.
    const TOL: f64 = 1e-4;
    let dnerf = |c2w: [[f64; 4]; 4], fov: f64| PinholeCamera::<f64>::from_dnerf(c2w, fov, 100, 80);
    for j in 0..4 {
        let mut off = C2W;
        off[3][j] += 10.0 * TOL;
        assert_eq!(
            dnerf(off, FOV_X).err(),
            Some(CameraError::NotRigid),
            "bottom row entry {j} alone"
        );
    }
    for j in 0..3 {
        for s in [TOL, -TOL] {
            let mut edge = C2W;
            edge[3][j] = s;
            assert!(dnerf(edge, FOV_X).is_ok(), "bottom row entry {j} at {s}");
        }
    }
    assert_eq!(
        dnerf(C2W, core::f64::consts::PI).err(),
        Some(CameraError::BadIntrinsics),
        "a field of view of π"
    );
    assert!(dnerf(C2W, 3.1).is_ok(), "just under π");

    // A shear has determinant 1 exactly; only RᵀR − I (its entry (0, 1) is the shear) shows it.
    let k = K;
    let sheared = |a: f64| {
        let v = [
            [1.0, a, 0.0, 0.1],
            [0.0, 1.0, 0.0, 0.2],
            [0.0, 0.0, 1.0, 3.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        PinholeCamera::from_viewmat(v, k, 64, 48, 0.01, 100.0)
    };
    assert_eq!(sheared(0.1).err(), Some(CameraError::NotRigid), "shear 0.1");
    assert!(sheared(TOL).is_ok(), "shear at the tolerance");
    assert_eq!(
        sheared(2.0 * TOL).err(),
        Some(CameraError::NotRigid),
        "shear 2e-4"
    );

    // Every entry that is read is checked for finiteness, alone.
    let id = ID;
    let view = |v, k, near, far| PinholeCamera::from_viewmat(v, k, 64, 48, near, far).err();
    assert_eq!(view(id, k, 0.01, 100.0), None, "valid");
    for (i, j) in [(0, 0), (1, 1), (0, 2), (1, 2)] {
        let mut kn = k;
        kn[i][j] = f64::NAN;
        assert_eq!(
            view(id, kn, 0.01, 100.0),
            Some(CameraError::NonFinite),
            "K[{i}][{j}]"
        );
    }
    for (i, j) in [(0, 0), (1, 2), (2, 3), (3, 3)] {
        let mut vn = id;
        vn[i][j] = f64::INFINITY;
        assert_eq!(
            view(vn, k, 0.01, 100.0),
            Some(CameraError::NonFinite),
            "view[{i}][{j}]"
        );
    }
    assert_eq!(
        view(id, k, f64::NAN, 100.0),
        Some(CameraError::NonFinite),
        "near"
    );
    assert_eq!(
        view(id, k, 0.01, f64::NAN),
        Some(CameraError::NonFinite),
        "far"
    );
    assert_eq!(
        view(id, k, 0.01, f64::INFINITY),
        None,
        "an infinite far plane"
    );
}

#[test]
fn view_matrix_validation_checks_every_condition_alone() {
    const TOL: f64 = 1e-4;
    let k = K;
    let v = [
        [1.0, 0.0, 0.0, 0.1],
        [0.0, 1.0, 0.0, 0.2],
        [0.0, 0.0, 1.0, 3.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let view = |v, k, w, h, near, far| PinholeCamera::from_viewmat(v, k, w, h, near, far).err();
    assert_eq!(view(v, k, 64, 48, 0.01, 100.0), None, "valid");
    assert_eq!(
        view(v, k, 0, 48, 0.01, 100.0),
        Some(CameraError::EmptyImage),
        "no width"
    );
    assert_eq!(
        view(v, k, 64, 0, 0.01, 100.0),
        Some(CameraError::EmptyImage),
        "no height"
    );
    for (near, far) in [(0.0, 1.0), (-1.0, 1.0), (2.0, 2.0), (2.0, 1.0)] {
        assert_eq!(
            view(v, k, 64, 48, near, far),
            Some(CameraError::BadClipRange),
            "near {near}, far {far}"
        );
    }
    assert_eq!(
        view(v, k, 64, 48, 1e-300, 2e-300),
        None,
        "any 0 < near < far"
    );
    for (i, j) in [(0, 0), (1, 1)] {
        for f in [0.0, -50.0] {
            let mut kb = k;
            kb[i][j] = f;
            assert_eq!(
                view(v, kb, 64, 48, 0.01, 100.0),
                Some(CameraError::BadIntrinsics),
                "K[{i}][{j}] = {f}"
            );
        }
    }
    for j in 0..4 {
        let mut off = v;
        off[3][j] += 10.0 * TOL;
        assert_eq!(
            view(off, k, 64, 48, 0.01, 100.0),
            Some(CameraError::NotRigid),
            "bottom row entry {j} alone"
        );
        let mut neg = v;
        neg[3][j] -= 10.0 * TOL;
        assert_eq!(
            view(neg, k, 64, 48, 0.01, 100.0),
            Some(CameraError::NotRigid),
            "bottom row entry {j} alone, below"
        );
    }
    for j in 0..3 {
        for s in [TOL, -TOL] {
            let mut edge = v;
            edge[3][j] = s;
            assert_eq!(
                view(edge, k, 64, 48, 0.01, 100.0),
                None,
                "bottom row entry {j} at {s}"
            );
        }
    }
}

#[test]
fn look_at_checks_each_input_and_its_degeneracy_test_is_scale_free() {
    let (eye, target) = (Vec3::new(0.3, -0.2, 4.0), Vec3::new(0.05, 0.0, 0.0));
    let up = Vec3::new(0.0, 1.0, 0.0);
    let look = |eye, target, up, w, h| PinholeCamera::<f64>::look_at(eye, target, up, 0.8, w, h);
    assert!(look(eye, target, up, 8, 6).is_ok(), "valid");
    let nan = Vec3::new(0.0, f64::NAN, 0.0);
    for (case, what, want) in [
        ((nan, target, up, 8, 6), "eye", CameraError::NonFinite),
        ((eye, nan, up, 8, 6), "target", CameraError::NonFinite),
        ((eye, target, nan, 8, 6), "up", CameraError::NonFinite),
        ((eye, target, up, 0, 6), "no width", CameraError::EmptyImage),
        (
            (eye, target, up, 8, 0),
            "no height",
            CameraError::EmptyImage,
        ),
    ] {
        let (e, t, u, w, h) = case;
        assert_eq!(look(e, t, u, w, h).err(), Some(want), "{what}");
    }

    // `up` nearly parallel to the view: accepted while |fwd × up| > 1e-12 |fwd| |up|, at
    // every scale of the distance and of `up`, and giving the same camera at every scale.
    // (The eye is at the origin so that `target − eye` is exact at every distance.)
    let (eye, dir) = (Vec3::zero(), target - eye);
    let fwd = dir * (1.0 / dir.norm());
    let side = fwd.cross(up) * (1.0 / fwd.cross(up).norm());
    let reference = look(eye, dir, up, 8, 6).expect("valid");
    for dist in [1e-6, 1e-3, 1.0, 1e3, 1e6] {
        for scale in [1e-6, 1.0, 1e6] {
            let along = |eps: f64| (fwd + side * eps) * scale;
            assert!(
                look(eye, fwd * dist, along(1e-9), 8, 6).is_ok(),
                "distance {dist}, |up| {scale}: 1e-9 off the view is enough"
            );
            assert_eq!(
                look(eye, fwd * dist, along(1e-14), 8, 6).err(),
                Some(CameraError::DegenerateLookAt),
                "distance {dist}, |up| {scale}: 1e-14 off the view is not"
            );
            let cam = look(eye, dir * dist, up * scale, 8, 6).expect("valid");
            assert!(
                (cam.rotation - reference.rotation).max_abs() < 1e-12,
                "distance {dist}, |up| {scale}: the same axes"
            );
        }
    }
}

#[test]
fn centre_of_a_singular_rotation_and_gradient_sums() {
    // A rotation field that lost rank (a camera being optimised can pass through one) has no
    // inverse: the centre falls back to −Rᵀ t.
    let mut cam = PinholeCamera::<f64>::from_dnerf(C2W, FOV_X, 100, 80).expect("valid");
    cam.rotation = Mat3::diag(Vec3::new(1.0, 2.0, 0.0));
    cam.translation = Vec3::new(1.0, 2.0, 3.0);
    assert_eq!(cam.center(), Vec3::new(-1.0, -4.0, 0.0), "−Rᵀ t");

    let g = |s: f64| CameraGrad {
        rotation: Mat3::diag(Vec3::new(s, 2.0 * s, 3.0 * s)),
        translation: Vec3::new(4.0 * s, 5.0 * s, 6.0 * s),
        bottom: [7.0 * s, 8.0 * s, 9.0 * s, 10.0 * s],
    };
    let mut sum = g(1.0);
    sum.add(&g(2.0));
    assert_eq!(sum, g(3.0), "every part adds");
}
