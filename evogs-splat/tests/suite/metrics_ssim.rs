//! Properties of the 3DGS SSIM: a direct 11×11 correlation (no separable filter) as an
//! independent reference at every size, including images smaller than the window;
//! closed forms for constant images; identity, symmetry, the maximum at `a = b`;
//! accumulation and the fused pass; workspace reuse; `Par::Rayon` bitwise equal to
//! `Par::Seq`; f32 against f64.

use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use evogs_splat::Image;
use evogs_splat::ssim::{
    SSIM_C1, SSIM_C2, SsimWorkspace, d_ssim, d_ssim_vjp, gaussian_window, ssim, ssim_map, ssim_vjp,
};

fn random_image(w: usize, h: usize, rng: &mut SplitMix64) -> Image<f64> {
    Image::from_vec(w, h, (0..w * h * 3).map(|_| rng.next_f64()).collect()).expect("size")
}

fn perturbed(a: &Image<f64>, sigma: f64, rng: &mut SplitMix64) -> Image<f64> {
    let data = a
        .data()
        .iter()
        .map(|&x| (x + sigma * rng.normal()).clamp(0.0, 1.0))
        .collect();
    Image::from_vec(a.width(), a.height(), data).expect("size")
}

/// The SSIM map by the definition: a direct 2-D correlation with the 11×11 window `g gᵀ`
/// and zero padding, straight from the formula of the reference file's conventions.
fn direct_map(a: &Image<f64>, b: &Image<f64>) -> Vec<f64> {
    let g = gaussian_window::<f64>();
    let (w, h) = (a.width() as isize, a.height() as isize);
    let mut out = Vec::with_capacity(a.data().len());
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let [mut m1, mut m2, mut e11, mut e22, mut e12] = [0.0; 5];
                for i in 0..11 {
                    for j in 0..11 {
                        let (yy, xx) = (y + i - 5, x + j - 5);
                        if yy < 0 || yy >= h || xx < 0 || xx >= w {
                            continue;
                        }
                        let wt = g[i as usize] * g[j as usize];
                        let (p, q) = (
                            a.get(xx as usize, yy as usize)[c],
                            b.get(xx as usize, yy as usize)[c],
                        );
                        m1 += wt * p;
                        m2 += wt * q;
                        e11 += wt * p * p;
                        e22 += wt * q * q;
                        e12 += wt * p * q;
                    }
                }
                let (s11, s22, s12) = (e11 - m1 * m1, e22 - m2 * m2, e12 - m1 * m2);
                out.push(
                    ((2.0 * m1 * m2 + SSIM_C1) * (2.0 * s12 + SSIM_C2))
                        / ((m1 * m1 + m2 * m2 + SSIM_C1) * (s11 + s22 + SSIM_C2)),
                );
            }
        }
    }
    out
}

#[test]
fn separable_map_matches_the_direct_correlation() {
    let mut rng = SplitMix64::new(21);
    let mut worst: f64 = 0.0;
    for (w, h) in [
        (1, 1),
        (2, 1),
        (1, 3),
        (4, 3),
        (6, 6),
        (11, 11),
        (12, 5),
        (25, 17),
    ] {
        for sigma in [0.02, 0.3] {
            let a = random_image(w, h, &mut rng);
            let b = perturbed(&a, sigma, &mut rng);
            let map = ssim_map(&a, &b);
            let reference = direct_map(&a, &b);
            let err = map
                .data()
                .iter()
                .zip(&reference)
                .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(err < 1e-12, "{w}x{h}: map off by {err:.3e}");
            let mean = reference.iter().sum::<f64>() / reference.len() as f64;
            assert!(
                (ssim(&a, &b) - mean).abs() < 1e-13,
                "{w}x{h}: mean of the map"
            );
            worst = worst.max(err);
        }
    }
    println!("separable vs direct 11x11 correlation: worst map error {worst:.3e}");
}

#[test]
fn constant_images_match_the_closed_form_inside() {
    // Away from the border the window sums to 1 and every variance is 0, so
    // map = (2 c1 c2 + C1)/(c1² + c2² + C1) (the C2 factors cancel).
    let (c1, c2) = ([0.5, 0.1, 0.9], [0.52, 0.1, 0.3]);
    let (a, b) = (Image::filled(24, 16, c1), Image::filled(24, 16, c2));
    let map = ssim_map(&a, &b);
    for y in 5..11 {
        for x in 5..19 {
            for c in 0..3 {
                let expect =
                    (2.0 * c1[c] * c2[c] + SSIM_C1) / (c1[c] * c1[c] + c2[c] * c2[c] + SSIM_C1);
                let got = map.get(x, y)[c];
                assert!(
                    (got - expect).abs() < 1e-12,
                    "({x}, {y}, {c}): {got} vs {expect}"
                );
            }
        }
    }
    // The zero padding darkens the border windows: there the map differs.
    assert!(
        (map.get(0, 0)[2] - map.get(12, 8)[2]).abs() > 0.1,
        "border effect of zero padding"
    );
    assert!(
        (map.get(0, 0)[1] - 1.0).abs() < 1e-14,
        "equal constant channels give 1 everywhere"
    );
}

#[test]
fn identity_symmetry_and_maximum() {
    let mut rng = SplitMix64::new(22);
    let a = random_image(19, 14, &mut rng);
    let b = perturbed(&a, 0.2, &mut rng);
    assert!((ssim(&a, &a) - 1.0).abs() < 1e-14, "SSIM(a, a) = 1");
    assert!(d_ssim(&a, &a).abs() < 1e-14, "D-SSIM(a, a) = 0");
    assert!((ssim(&a, &b) - ssim(&b, &a)).abs() < 1e-15, "symmetric");
    assert!(ssim(&a, &b) < 1.0, "below 1 for different images");
    // a = b is a maximum of every map value: the gradient vanishes.
    let mut g = Image::new(19, 14);
    ssim_vjp(&a, &a, 1.0, &mut g);
    let gmax = g.data().iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    assert!(gmax < 1e-15, "gradient at a = b is {gmax:.3e}");
    // D-SSIM is (1 − SSIM)/2, its gradient −1/2 of SSIM's.
    assert!(
        (d_ssim(&a, &b) - (1.0 - ssim(&a, &b)) / 2.0).abs() < 1e-16,
        "D-SSIM value"
    );
    let (mut gs, mut gd) = (Image::new(19, 14), Image::new(19, 14));
    ssim_vjp(&a, &b, -0.5, &mut gs);
    d_ssim_vjp(&a, &b, 1.0, &mut gd);
    assert_eq!(gs, gd, "D-SSIM gradient");
}

#[test]
fn fused_pass_accumulates_and_matches_the_parts() {
    let mut rng = SplitMix64::new(23);
    let a = random_image(31, 22, &mut rng);
    let b = perturbed(&a, 0.1, &mut rng);
    let mut ws = SsimWorkspace::new();
    let (mut once, mut twice) = (Image::new(31, 22), Image::new(31, 22));
    let s = ws.ssim_and_grad(&a, &b, 2.0, &mut once, Par::Seq);
    assert_eq!(
        s.to_bits(),
        ws.ssim(&a, &b, Par::Seq).to_bits(),
        "value of the fused pass"
    );
    assert_eq!(
        s.to_bits(),
        ssim(&a, &b).to_bits(),
        "workspace and free function"
    );
    ws.ssim_and_grad(&a, &b, 1.0, &mut twice, Par::Seq);
    ws.ssim_and_grad(&a, &b, 1.0, &mut twice, Par::Seq);
    assert_eq!(
        once, twice,
        "the gradient is added, and scales with the cotangent"
    );
    let mut free = Image::new(31, 22);
    ssim_vjp(&a, &b, 2.0, &mut free);
    assert_eq!(once, free, "free function and workspace");
}

#[test]
fn workspace_reuse_across_sizes_gives_fresh_results() {
    let mut rng = SplitMix64::new(24);
    let mut ws = SsimWorkspace::with_size(40, 30);
    for (w, h) in [(40, 30), (7, 9), (40, 30), (41, 3), (2, 2), (13, 50)] {
        let a = random_image(w, h, &mut rng);
        let b = perturbed(&a, 0.1, &mut rng);
        let (mut g_reused, mut g_fresh) = (Image::new(w, h), Image::new(w, h));
        let s1 = ws.ssim_and_grad(&a, &b, 1.0, &mut g_reused, Par::Seq);
        let s2 = SsimWorkspace::new().ssim_and_grad(&a, &b, 1.0, &mut g_fresh, Par::Seq);
        assert_eq!(s1.to_bits(), s2.to_bits(), "{w}x{h}: value after reuse");
        assert_eq!(g_reused, g_fresh, "{w}x{h}: gradient after reuse");
        let (mut m1, mut m2) = (Image::new(w, h), Image::new(w, h));
        ws.ssim_map(&a, &b, &mut m1, Par::Seq);
        SsimWorkspace::new().ssim_map(&a, &b, &mut m2, Par::Seq);
        assert_eq!(m1, m2, "{w}x{h}: map after reuse");
    }
}

#[cfg(feature = "rayon")]
#[test]
fn rayon_is_bitwise_identical_to_sequential() {
    let mut rng = SplitMix64::new(25);
    for (w, h) in [(97, 61), (5, 300), (300, 4)] {
        let a = random_image(w, h, &mut rng).cast::<f32>();
        let b = perturbed(&a.cast(), 0.1, &mut rng).cast::<f32>();
        let mut ws = SsimWorkspace::new();
        let (mut gs, mut gr) = (Image::new(w, h), Image::new(w, h));
        let ss = ws.ssim_and_grad(&a, &b, 1.0, &mut gs, Par::Seq);
        let sr = ws.ssim_and_grad(&a, &b, 1.0, &mut gr, Par::Rayon);
        assert_eq!(ss.to_bits(), sr.to_bits(), "{w}x{h}: SSIM value");
        let same = gs
            .data()
            .iter()
            .zip(gr.data())
            .all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{w}x{h}: gradient");
        let (mut ms, mut mr) = (Image::new(w, h), Image::new(w, h));
        ws.ssim_map(&a, &b, &mut ms, Par::Seq);
        ws.ssim_map(&a, &b, &mut mr, Par::Rayon);
        let same = ms
            .data()
            .iter()
            .zip(mr.data())
            .all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{w}x{h}: map");
    }
}

#[test]
fn f32_agrees_with_f64() {
    let mut rng = SplitMix64::new(26);
    let a = random_image(64, 48, &mut rng);
    let b = perturbed(&a, 0.1, &mut rng);
    let (a32, b32) = (a.cast::<f32>(), b.cast::<f32>());
    // Compare against f64 evaluated on the f32-rounded inputs.
    let (a, b) = (a32.cast::<f64>(), b32.cast::<f64>());
    let mut ws32 = SsimWorkspace::<f32>::new();
    let mut ws64 = SsimWorkspace::<f64>::new();
    let (mut g32, mut g64) = (Image::new(64, 48), Image::new(64, 48));
    let s32 = ws32.ssim_and_grad(&a32, &b32, 1.0, &mut g32, Par::Seq);
    let s64 = ws64.ssim_and_grad(&a, &b, 1.0, &mut g64, Par::Seq);
    let err = (f64::from(s32) - s64).abs();
    assert!(err < 1e-6, "f32 SSIM off by {err:.3e}");
    let gmax = g64.data().iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let gerr = g32
        .cast::<f64>()
        .data()
        .iter()
        .zip(g64.data())
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        gerr < 1e-4 * gmax,
        "f32 gradient off by {:.3e} of its maximum",
        gerr / gmax
    );
    println!(
        "f32 vs f64 (64x48): SSIM {err:.3e}, gradient {:.3e} of max",
        gerr / gmax
    );
}
