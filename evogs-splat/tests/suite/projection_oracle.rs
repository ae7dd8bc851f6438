//! Parity of the projection and its VJP with the gsplat 1.5.3 reference vectors
//! (`tests/data/oracle/projection_shared_case*.json`, conventions in SCHEMA.md).
//!
//! Tolerances are the oracle README's f64 column: outputs 1e-10 relative, VJPs 1e-9
//! relative to `max(1, |ref|)`. Run with `--nocapture` to see the worst errors.

use crate::splat_common;

use evogs_math::covariance::covariance;
use evogs_math::{Quat, Vec2, Vec3};
use evogs_splat::{
    CameraGrad, PinholeCamera, ProjectOptions, Projected, ProjectedGrad, RadiusMode, Splats,
    project, project_vjp,
};
use serde_json::Value;
use splat_common::{Cmp, bools, camera, flat, int, load, num, splats};

const FILES: [&str; 2] = [
    "projection_shared_case00.json",
    "projection_shared_case03.json",
];
const OUT_TOL: f64 = 1e-10;
const VJP_TOL: f64 = 1e-9;

fn opts(eps2d: f64, radius: RadiusMode) -> ProjectOptions<f64> {
    ProjectOptions {
        eps2d,
        radius,
        antialiased: false,
    }
}

fn project_all(
    s: &Splats<f64>,
    cam: &PinholeCamera<f64>,
    o: &ProjectOptions<f64>,
    op: &[f64],
) -> Vec<Projected<f64>> {
    (0..s.len())
        .map(|i| project(s.means[i], s.log_scales[i], s.quats[i], op[i], cam, o))
        .collect()
}

/// Selects the entries of rows with `mask` (each row `width` numbers).
fn rows(v: &[f64], width: usize, mask: &[bool]) -> Vec<f64> {
    v.chunks(width)
        .zip(mask)
        .filter(|(_, m)| **m)
        .flat_map(|(r, _)| r.to_vec())
        .collect()
}

#[test]
fn projection_outputs_match_gsplat() {
    for file in FILES {
        println!("{file}: outputs");
        let v = load(file);
        let case = &v["case"];
        let inputs = &case["inputs"];
        let out = &case["outputs"];
        let cam = camera(inputs);
        let s = splats(inputs);
        let op = flat(&inputs["opacities"]);
        let eps2d = num(&inputs["eps2d"]);
        let plain = project_all(&s, &cam, &opts(eps2d, RadiusMode::Plain), &op);
        let aware = project_all(&s, &cam, &opts(eps2d, RadiusMode::OpacityAware), &op);
        let valid = bools(&out["valid"]);
        let all = vec![true; s.len()];

        let mine_valid: Vec<bool> = plain.iter().map(|p| p.valid).collect();
        assert_eq!(mine_valid, valid, "valid flags");
        let radii: Vec<f64> = plain.iter().flat_map(|p| p.radii.map(f64::from)).collect();
        assert!(radii == flat(&out["radii"]), "radii");
        let radii_oa: Vec<f64> = aware.iter().flat_map(|p| p.radii.map(f64::from)).collect();
        assert!(
            radii_oa == flat(&out["radii_opacity_aware"]),
            "opacity-aware radii"
        );
        let fx: Vec<bool> = plain.iter().map(|p| p.fov_clamped[0]).collect();
        let fy: Vec<bool> = plain.iter().map(|p| p.fov_clamped[1]).collect();
        assert_eq!(fx, bools(&out["fov_clamped_x"]), "fov_clamped_x");
        assert_eq!(fy, bools(&out["fov_clamped_y"]), "fov_clamped_y");
        println!("  valid, radii, radii_opacity_aware, fov_clamped_x/y: exact");

        let cmp = |name: &str, mine: Vec<f64>, key: &str, width: usize, mask: &[bool]| {
            let r = rows(&flat(&out[key]), width, mask);
            Cmp::new(name, &rows(&mine, width, mask), &r, OUT_TOL, 1e-3).check();
        };
        let mc: Vec<f64> = plain.iter().flat_map(|p| p.mean_cam.to_array()).collect();
        cmp("means_cam (all)", mc, "means_cam", 3, &all);
        let cw: Vec<f64> = (0..s.len())
            .flat_map(|i| covariance(s.log_scales[i], s.quats[i]).to_mat().to_flat())
            .collect();
        cmp("covars_world (all)", cw, "covars_world", 9, &all);
        let d: Vec<f64> = plain.iter().map(|p| p.depth).collect();
        cmp("depths (all)", d, "depths", 1, &all);
        let c2: Vec<f64> = plain
            .iter()
            .flat_map(|p| [p.cov2d.xx, p.cov2d.xy, p.cov2d.xy, p.cov2d.yy])
            .collect();
        cmp("cov2d", c2, "cov2d", 4, &valid);
        let cb: Vec<f64> = plain
            .iter()
            .flat_map(|p| {
                let b = p.cov2d_blurred(eps2d);
                [b.xx, b.xy, b.xy, b.yy]
            })
            .collect();
        cmp("cov2d_blurred", cb, "cov2d_blurred", 4, &valid);
        let m2: Vec<f64> = plain.iter().flat_map(|p| p.means2d.to_array()).collect();
        cmp("means2d", m2.clone(), "means2d", 2, &valid);
        let co: Vec<f64> = plain.iter().flat_map(|p| p.conic).collect();
        cmp("conics", co.clone(), "conics", 3, &valid);
        let cp: Vec<f64> = plain.iter().map(|p| p.compensation).collect();
        cmp("compensations", cp.clone(), "compensations", 1, &valid);
        // Culled Gaussians: the plain formulas are kept too and match the reference.
        let culled: Vec<bool> = valid.iter().map(|v| !v).collect();
        for (name, mine, key, w) in [
            ("culled means2d", m2, "means2d", 2),
            ("culled conics", co, "conics", 3),
            ("culled compensations", cp, "compensations", 1),
        ] {
            let r = rows(&flat(&out[key]), w, &culled);
            Cmp::new(name, &rows(&mine, w, &culled), &r, OUT_TOL, 1e-3).check();
        }
    }
}

/// Which cotangents a `grads` object of the oracle includes.
struct Parts {
    means2d: bool,
    depths: bool,
    conics: bool,
    compensations: bool,
}

/// Summed VJP over all Gaussians: means, quats, scales (flat), viewmat, pose.
type VjpSum = (Vec<f64>, Vec<f64>, Vec<f64>, [[f64; 4]; 4], [f64; 6]);

fn vjp_sum(case: &Value, parts: &Parts) -> VjpSum {
    let inputs = &case["inputs"];
    let cam = camera(inputs);
    let s = splats(inputs);
    let op = flat(&inputs["opacities"]);
    let o = opts(num(&inputs["eps2d"]), RadiusMode::Plain);
    let ct = &case["vjp"]["cotangents"];
    let (m2, dep, con, comp) = (
        flat(&ct["means2d"]),
        flat(&ct["depths"]),
        flat(&ct["conics"]),
        flat(&ct["compensations"]),
    );
    let pick = |on: bool, x: f64| if on { x } else { 0.0 };
    let (mut dm, mut dq, mut ds) = (Vec::new(), Vec::new(), Vec::new());
    let mut cam_grad = CameraGrad::zero();
    for i in 0..s.len() {
        let d = ProjectedGrad {
            means2d: Vec2::new(
                pick(parts.means2d, m2[2 * i]),
                pick(parts.means2d, m2[2 * i + 1]),
            ),
            depth: pick(parts.depths, dep[i]),
            conic: std::array::from_fn(|k| pick(parts.conics, con[3 * i + k])),
            compensation: pick(parts.compensations, comp[i]),
        };
        let g = project_vjp(s.means[i], s.log_scales[i], s.quats[i], op[i], &cam, &o, &d);
        dm.extend(g.mean.to_array());
        dq.extend(g.quat.to_array());
        // d/ds = (d/dŝ)/s, ŝ = ln s.
        let sc = s.log_scales[i].map(f64::exp);
        ds.extend(
            (g.log_scale
                .mul_elem(Vec3::new(1.0 / sc.x, 1.0 / sc.y, 1.0 / sc.z)))
            .to_array(),
        );
        cam_grad.add(&g.camera);
    }
    (
        dm,
        dq,
        ds,
        cam_grad.to_viewmat(),
        cam_grad.to_pose_left_se3(&cam),
    )
}

#[test]
fn projection_vjps_match_gsplat() {
    let all = || Parts {
        means2d: true,
        depths: true,
        conics: true,
        compensations: true,
    };
    let only = |k: &str| Parts {
        means2d: k == "means2d",
        depths: k == "depths",
        conics: k == "conics",
        compensations: k == "compensations",
    };
    for file in FILES {
        println!("{file}: VJPs");
        let v = load(file);
        let case = &v["case"];
        let mut variants: Vec<(String, &Value, Parts)> = vec![
            (
                "grads".into(),
                &case["vjp"]["grads"],
                Parts {
                    compensations: false,
                    ..all()
                },
            ),
            (
                "grads_with_compensations".into(),
                &case["vjp"]["grads_with_compensations"],
                all(),
            ),
        ];
        for k in ["means2d", "depths", "conics", "compensations"] {
            variants.push((
                format!("per_output.{k}"),
                &case["vjp"]["grads_per_output"][k],
                only(k),
            ));
        }
        for (name, reference, parts) in variants {
            let (dm, dq, ds, vm, pose) = vjp_sum(case, &parts);
            let c = |q: &str, mine: &[f64], key: &str| {
                Cmp::new(
                    &format!("{name}.{q}"),
                    mine,
                    &flat(&reference[key]),
                    VJP_TOL,
                    1.0,
                )
                .check();
            };
            c("means", &dm, "means");
            c("quats", &dq, "quats");
            c("scales", &ds, "scales");
            c("viewmat", &vm.concat(), "viewmat");
            c("pose_left_se3", &pose, "pose_left_se3");
        }
    }
}

#[test]
fn oracle_quaternion_gradients_are_tangential() {
    // The reference gradients are orthogonal to q (normalisation inside); so are ours.
    for file in FILES {
        let v = load(file);
        let case = &v["case"];
        let s = splats(&case["inputs"]);
        let (_, dq, _, _, _) = vjp_sum(
            case,
            &Parts {
                means2d: true,
                depths: true,
                conics: true,
                compensations: true,
            },
        );
        for i in 0..s.len() {
            let g = Quat::from_slice(&dq[4 * i..]);
            assert!(
                g.dot(s.quats[i]).abs() < 1e-10 * (1.0 + g.norm()),
                "dq ⟂ q for Gaussian {i}"
            );
        }
        let _ = int(&case["inputs"]["width"]);
    }
}
