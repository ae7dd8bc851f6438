//! What the searches' tests share: a small field, a static model, canonical poses and views
//! of a scene with some of its Gaussians turned rigidly.

use crate::field::{HexPlaneConfig, NeuralField, NeuralFieldConfig, TimeMapping};
use crate::model::{Model, Motion, Waypoints};
use crate::train::step::ViewData;
use evogs_math::so3::exp_quat;
use evogs_math::{Quat, Vec3};
use evogs_ode::Method;
use evogs_splat::{PinholeCamera, RenderOptions, Splats, TiledRasterizer, render_tiled};

/// A small zero-initialised field for the searches' tests.
pub(crate) fn test_field() -> NeuralField<f32> {
    let cfg = NeuralFieldConfig {
        hexplane: HexPlaneConfig {
            channels: 8,
            resolution: [8, 8, 8, 6],
            multires: vec![1],
        },
        width: 16,
        output_scales: [1.0, 1.0, 1.0],
        zero_init_output: true,
        twist: false,
    };
    let time = TimeMapping::Normalized {
        t_min: 0.0,
        t_max: 1.0,
    };
    NeuralField::new(&cfg, [-1.0; 3], [3.0; 3], time, 4)
}

/// `splats` without motion (RK4, one anchor), [`test_field`] unused.
pub(crate) fn static_model(splats: &Splats<f32>) -> Model<f32> {
    Model::new(
        splats.clone(),
        test_field(),
        Motion::Static,
        Waypoints::Off,
        Method::Rk4,
        0.25,
        vec![0.0],
    )
}

/// The canonical positions and unit orientations of `splats`, in f64.
pub(crate) fn canonical_poses(splats: &Splats<f32>) -> (Vec<Vec3<f64>>, Vec<Quat<f64>>) {
    (
        splats.means.iter().map(|m| m.cast()).collect(),
        splats.quats.iter().map(|q| q.normalize().cast()).collect(),
    )
}

/// The view at `time` from `camera` of `splats` with `members` turned rigidly at `omega`
/// (radians per unit time, from time 0) about `centre`.
#[allow(clippy::too_many_arguments, reason = "the view's whole description")]
pub(crate) fn turned_view(
    splats: &Splats<f32>,
    members: impl IntoIterator<Item = usize>,
    (centre, omega): (Vec3<f64>, Vec3<f64>),
    time: f64,
    camera: PinholeCamera<f32>,
    opts: &RenderOptions<f32>,
    rast: &mut TiledRasterizer<f32>,
) -> ViewData<f32> {
    let mut st = splats.clone();
    let turn = exp_quat(omega * time);
    for i in members {
        let (p, q): (Vec3<f64>, Quat<f64>) = (st.means[i].cast(), st.quats[i].normalize().cast());
        st.means[i] = (centre + turn.rotate(p - centre)).cast();
        st.quats[i] = turn.mul_quat(q).cast();
    }
    let image = render_tiled(&st, &camera, opts, rast).raster.rgb.clone();
    ViewData {
        camera,
        time,
        image,
    }
}
