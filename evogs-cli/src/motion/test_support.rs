//! What the searches' tests share: a small field, a static model, canonical poses and views
//! of a scene with some of its Gaussians turned rigidly.

use super::OrbitSearchConfig;
use super::orbit::{Found, Group, Orbit, canonical_groups, search};
use super::spin::SearchContext;
use super::spin::place;
use crate::field::{HexPlaneConfig, NeuralField, NeuralFieldConfig, TimeMapping};
use crate::model::{Model, Motion, Waypoints};
use crate::train::step::ViewData;
use evogs_math::Par;
use evogs_math::so3::exp_quat;
use evogs_math::{Quat, Vec3};
use evogs_ode::Method;
use evogs_splat::{
    PinholeCamera, RenderOptions, Splats, TiledRasterizer, random_scene, render_tiled,
};

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
    rendered_view(&st, camera, time, opts, rast)
}

/// The view at `time` from `camera` of `st` as it is.
pub(crate) fn rendered_view(
    st: &Splats<f32>,
    camera: PinholeCamera<f32>,
    time: f64,
    opts: &RenderOptions<f32>,
    rast: &mut TiledRasterizer<f32>,
) -> ViewData<f32> {
    let image = render_tiled(st, &camera, opts, rast).raster.rgb.clone();
    ViewData {
        camera,
        time,
        image: image.into(),
    }
}

/// A search context over `views` of `splats` (sequential, D-SSIM weight 0.2).
pub(crate) fn test_context<'a>(
    views: &'a [ViewData<f32>],
    splats: &Splats<f32>,
    opts: RenderOptions<f32>,
) -> SearchContext<'a> {
    let (p0, q0) = canonical_poses(splats);
    SearchContext {
        views: views.iter().collect(),
        opts,
        lambda: 0.2,
        p0,
        q0,
        log_scales: splats.log_scales.clone(),
        par: Par::Seq,
    }
}

/// The orbit tests' views: times 0.05, 0.10, …, 0.60, every other one from [`side_camera`]
/// (so that motion in depth shows too) and the rest from `camera`; `view` renders each.
pub(crate) fn two_camera_views(
    camera: PinholeCamera<f32>,
    mut view: impl FnMut(f64, PinholeCamera<f32>) -> ViewData<f32>,
) -> Vec<ViewData<f32>> {
    let side = side_camera();
    (1..=12)
        .map(|k| {
            let time = f64::from(k) * 0.05;
            view(time, if k % 2 == 0 { camera } else { side })
        })
        .collect()
}

/// A scene of two groups: 200 Gaussians in a ball of radius 0.3 about the origin and 60 in
/// a ball of radius 0.06 about (0.6, 0, 0), and a camera on the +z axis.
pub(crate) fn two_groups() -> (Splats<f32>, PinholeCamera<f32>) {
    let (mut s, cam) = random_scene::<f32>(260, 48, 3, [0.02, 0.05], [0.7, 0.9]);
    for (i, m) in s.means.iter_mut().enumerate() {
        let (c, r) = if i < 200 {
            (Vec3::zero(), 0.3)
        } else {
            (Vec3::new(0.6, 0.0, 0.0), 0.06)
        };
        // The uniform cube [−0.5, 0.5]³ shrunk to fit inside the ball.
        *m = (c + m.cast::<f64>() * (r / 0.87)).cast();
    }
    (s, cam)
}

/// A camera of [`two_groups`]'s size from the side (−y), so that motion in depth shows too.
pub(crate) fn side_camera() -> PinholeCamera<f32> {
    PinholeCamera::look_at(
        Vec3::new(0.0, -4.0, 1.0),
        Vec3::zero(),
        Vec3::new(0.0, 0.0, 1.0),
        40.0_f64.to_radians(),
        48,
        48,
    )
    .expect("a valid camera")
}

/// Orbit search settings for [`two_groups`].
pub(crate) fn orbit_test_cfg() -> OrbitSearchConfig {
    OrbitSearchConfig {
        min_body: 20,
        link: 0.15,
        max_radius: 0.15,
        centre_min_body: 100,
        centre_max_radius: 0.5,
        max_speed: 4.0,
        speed_step: 0.5,
        horizons: vec![0.15, 0.3, 0.6],
        max_spin: 6.0,
        spin_step: 1.0,
        view_stride: 1,
        min_gain: 0.0,
        ..OrbitSearchConfig::default()
    }
}

/// The orbit search on `groups` over the time range [0, 1], its log pushed into `lines`.
pub(crate) fn orbit_search_logged(
    model: &mut Model<f32>,
    ctx: &mut SearchContext<'_>,
    groups: &[Group],
    cfg: &OrbitSearchConfig,
    lines: &mut Vec<String>,
) -> Vec<Found> {
    search(model, ctx, groups, (0.0, 1.0), cfg, &mut None, &mut |m| {
        lines.push(m.to_string());
    })
}

/// [`two_groups`] with the small group stretched into a rod along x (so that its own turn
/// shows), circling the large group at 4 rad per unit time about z while it tumbles about
/// (0, 3, 1), and [`two_camera_views`] of it: the splats, the views, the groups and the
/// rod's true orbit.
pub(crate) fn tumbling_rod() -> (Splats<f32>, Vec<ViewData<f32>>, Vec<Group>, Orbit) {
    let (mut splats, camera) = two_groups();
    let c = Vec3::new(0.6, 0.0, 0.0);
    for m in &mut splats.means[200..] {
        let d = m.cast::<f64>() - c;
        *m = (c + Vec3::new(d.x * 1.8, d.y * 0.5, d.z * 0.5)).cast();
    }
    let (p0, q0) = canonical_poses(&splats);
    let groups = canonical_groups(&p0, &splats.opacity_logits, &orbit_test_cfg());
    assert_eq!(groups.len(), 2);
    let truth = Orbit::through(
        groups[1].centroid,
        groups[0].centroid,
        Vec3::new(0.0, 2.4, 0.0),
    )
    .with_spin(Vec3::new(0.0, 3.0, 1.0));
    let body = truth.body(&groups[1], (0.0, 1.0));
    let opts = crate::train::step::render_options([1.0; 3], splats.sh_degree, Par::Seq);
    let mut rast = TiledRasterizer::new();
    let views = two_camera_views(camera, |time, camera| {
        let mut st = splats.clone();
        place(&mut st, &body, time, 1.0, &p0, &q0, &splats.log_scales);
        rendered_view(&st, camera, time, &opts, &mut rast)
    });
    (splats, views, groups, truth)
}
