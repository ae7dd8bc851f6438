//! Projection and rasterization (`evogs-splat`) on arbitrary floats: a handful of Gaussians
//! with any means, log-scales, quaternions, opacity logits and SH coefficients, seen by a
//! camera whose every field comes from the input, rendered by the reference and the tiled
//! rasterizer (classic or antialiased, SH degree 0 to 3).
//!
//! Each float is either a raw bit pattern (NaN, infinities, huge and subnormal values) or a
//! moderate value, chosen by a byte, so that both hostile and ordinary scenes are reached.
//!
//! Properties: nothing panics or hangs, whatever the numbers; with finite Gaussians and a
//! camera built by `PinholeCamera::look_at` (a valid camera), every output is finite (also
//! with the tiled rasterizer's default fast exponential), and the reference and the tiled
//! rasterizer with `ExpMode::Exact` return the same images bit for bit (as the crate
//! documents; the default `ExpMode::Fast` may differ by an ulp).
#![no_main]

use evogs_math::{Mat3, Par, Quat, Vec3};
use evogs_splat::{
    ExpMode, PinholeCamera, RasterMode, Render, RenderOptions, Splats, TiledRasterizer, render,
    render_tiled,
};
use libfuzzer_sys::fuzz_target;

/// Reads values from the fuzz input; zeros once it is exhausted.
struct Input<'a>(&'a [u8]);

impl Input<'_> {
    fn byte(&mut self) -> u8 {
        let Some((&b, rest)) = self.0.split_first() else {
            return 0;
        };
        self.0 = rest;
        b
    }

    fn bytes<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        for b in &mut out {
            *b = self.byte();
        }
        out
    }

    /// A raw `f32` bit pattern (selector byte < 32) or a moderate value in about ±8.
    fn float(&mut self) -> f32 {
        if self.byte() < 32 {
            f32::from_le_bytes(self.bytes::<4>())
        } else {
            f32::from(i16::from_le_bytes(self.bytes::<2>())) / 4096.0
        }
    }

    fn vec3(&mut self) -> Vec3<f32> {
        Vec3::new(self.float(), self.float(), self.float())
    }
}

fn finite(r: &Render<f32>) -> bool {
    let o = &r.raster;
    o.rgb.data().iter().all(|v| v.is_finite())
        && o.alpha.iter().all(|v| v.is_finite())
        && o.depth.iter().all(|v| v.is_finite())
        && o.final_t.iter().all(|v| v.is_finite())
}

fuzz_target!(|data: &[u8]| {
    let mut inp = Input(data);
    let width = usize::from(inp.byte() % 40) + 1;
    let height = usize::from(inp.byte() % 40) + 1;
    let sh_degree = usize::from(inp.byte() % 4);
    let mode = if inp.byte() % 2 == 0 {
        RasterMode::Classic
    } else {
        RasterMode::Antialiased
    };
    let active_degree = usize::from(inp.byte() % 4);

    // Either a validated look-at camera or every field raw.
    let camera = if inp.byte() % 2 == 0 {
        let (eye, target, up) = (inp.vec3(), inp.vec3(), inp.vec3());
        let fov = inp.float();
        PinholeCamera::<f32>::look_at(
            eye.cast(),
            target.cast(),
            up.cast(),
            f64::from(fov),
            width,
            height,
        )
        .ok()
        .map(|c| (c, true))
    } else {
        let rows = [inp.vec3(), inp.vec3(), inp.vec3()].map(Vec3::to_array);
        Some((
            PinholeCamera {
                rotation: Mat3::from_rows(rows),
                translation: inp.vec3(),
                fx: inp.float(),
                fy: inp.float(),
                cx: inp.float(),
                cy: inp.float(),
                width,
                height,
                near: inp.float(),
                far: inp.float(),
            },
            false,
        ))
    };
    let Some((camera, valid_camera)) = camera else {
        return;
    };

    let n = usize::from(inp.byte() % 8);
    let mut splats = Splats::<f32>::new(sh_degree);
    let coeffs = splats.coeffs_per_gaussian();
    for _ in 0..n {
        let mean = inp.vec3();
        let log_scale = inp.vec3();
        let quat = Quat::new(inp.float(), inp.float(), inp.float(), inp.float());
        let opacity = inp.float();
        let sh: Vec<[f32; 3]> = (0..coeffs).map(|_| inp.vec3().to_array()).collect();
        splats.push(mean, log_scale, quat, opacity, &sh);
    }
    let opts = RenderOptions {
        mode,
        sh_degree: active_degree,
        background: [inp.float(), inp.float(), inp.float()],
        par: Par::Seq,
        ..RenderOptions::default()
    };

    let reference = render(&splats, &camera, &opts);
    let tiled = render_tiled(
        &splats,
        &camera,
        &opts,
        &mut TiledRasterizer::with_exp(ExpMode::Exact),
    );
    let fast = render_tiled(&splats, &camera, &opts, &mut TiledRasterizer::new());

    let finite_input = splats
        .means
        .iter()
        .chain(&splats.log_scales)
        .all(|v| v.is_finite())
        && splats
            .quats
            .iter()
            .all(|q| [q.w, q.x, q.y, q.z].iter().all(|v| v.is_finite()))
        && splats.opacity_logits.iter().all(|v| v.is_finite())
        && splats.sh.iter().flatten().all(|v| v.is_finite())
        && opts.background.iter().all(|v| v.is_finite());
    if valid_camera && finite_input {
        assert!(
            finite(&reference),
            "reference render not finite: {splats:?} {camera:?}"
        );
        assert!(
            finite(&tiled),
            "tiled render not finite: {splats:?} {camera:?}"
        );
        assert!(
            finite(&fast),
            "tiled render (fast exp) not finite: {splats:?} {camera:?}"
        );
        assert!(
            reference.raster == tiled.raster,
            "reference and tiled images differ: {splats:?} {camera:?} {opts:?}"
        );
    }
});
