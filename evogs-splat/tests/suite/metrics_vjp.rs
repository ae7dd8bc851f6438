//! Every VJP of the losses and metrics (L1, L2, PSNR, SSIM, D-SSIM, the 3DGS photometric
//! loss) against central differences in f64 and by the dot-product test with dual-number
//! JVPs, on small random images (smaller and larger than the 11×11 window).

use evogs_math::diff::{GradCheck, central_gradient, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_math::{Dual, Par, Real};
use evogs_splat::Image;
use evogs_splat::loss::{l1, l1_vjp, l2, l2_vjp, photometric_loss, photometric_loss_and_grad};
use evogs_splat::metrics::{psnr, psnr_vjp};
use evogs_splat::ssim::{SsimWorkspace, d_ssim, d_ssim_vjp, ssim, ssim_vjp};

/// Sizes: below the window, around it, and with a full interior.
const SIZES: [(usize, usize); 4] = [(1, 1), (4, 3), (11, 7), (17, 13)];

fn random_image(w: usize, h: usize, rng: &mut SplitMix64) -> Image<f64> {
    Image::from_vec(w, h, (0..w * h * 3).map(|_| rng.next_f64()).collect()).expect("size")
}

/// `b` = `a` plus noise of size `sigma`, clamped to [0, 1] (a realistic render/target pair).
fn perturbed(a: &Image<f64>, sigma: f64, rng: &mut SplitMix64) -> Image<f64> {
    let data = a
        .data()
        .iter()
        .map(|&x| (x + sigma * rng.normal()).clamp(0.0, 1.0))
        .collect();
    Image::from_vec(a.width(), a.height(), data).expect("size")
}

fn from_slice<T: Real>(like: &Image<f64>, v: &[T]) -> Image<T> {
    Image::from_vec(like.width(), like.height(), v.to_vec()).expect("size")
}

type Loss = fn(&Image<f64>, &Image<f64>) -> f64;
type LossDual = fn(&Image<Dual<f64>>, &Image<Dual<f64>>) -> Dual<f64>;
type Vjp = fn(&Image<f64>, &Image<f64>, f64, &mut Image<f64>);

/// Central differences and the dual dot-product test for one loss on one image pair.
fn check(
    name: &str,
    f: Loss,
    f_dual: LossDual,
    vjp: Vjp,
    a: &Image<f64>,
    b: &Image<f64>,
    tol: GradCheck,
) {
    let n = a.data().len();
    let mut analytic = Image::new(a.width(), a.height());
    vjp(a, b, 1.0, &mut analytic);
    let mut x = a.data().to_vec();
    let mut numeric = vec![0.0; n];
    central_gradient(|v: &[f64]| f(&from_slice(a, v), b), &mut x, &mut numeric);
    let report = tol.check(analytic.data(), &numeric);
    report.assert_passed(&format!("{name} {}x{}", a.width(), a.height()));

    let b_dual = b.cast::<Dual<f64>>();
    let jvp = |v: &[f64], out: &mut [f64]| {
        let xd: Vec<Dual<f64>> = a
            .data()
            .iter()
            .zip(v)
            .map(|(&x, &e)| Dual::new(x, e))
            .collect();
        out[0] = f_dual(&from_slice(a, &xd), &b_dual).eps;
    };
    let vjp_w = |w: &[f64], out: &mut [f64]| {
        let mut g = Image::new(a.width(), a.height());
        vjp(a, b, w[0], &mut g);
        out.copy_from_slice(g.data());
    };
    let mismatch = vjp_dot_test(jvp, vjp_w, n, 1, 7);
    assert!(
        mismatch < 1e-13,
        "{name}: dot-product mismatch {mismatch:.3e}"
    );
    println!(
        "{name:>7} {:>2}x{:<2}: {report}; dot test {mismatch:.1e}",
        a.width(),
        a.height()
    );
}

#[test]
fn l1_vjp_matches_fd_and_dual() {
    let mut rng = SplitMix64::new(11);
    for (w, h) in SIZES {
        let a = random_image(w, h, &mut rng);
        // Keep every |a − b| well above the difference step so no kink is crossed.
        let data = a
            .data()
            .iter()
            .map(|&x| if x > 0.5 { x - 0.3 } else { x + 0.3 })
            .collect();
        let b = Image::from_vec(w, h, data).expect("size");
        // Central differences of a piecewise-linear mean are exact up to rounding, ε·|L1|/h ≈ 5e-12.
        check("l1", l1, l1, l1_vjp, &a, &b, GradCheck::new(5e-11, 1e-9));
    }
}

#[test]
fn l1_subgradient_is_zero_at_equal_values() {
    let a = Image::from_vec(2, 1, vec![0.5, 0.25, 0.75, 0.0, 1.0, 0.5]).expect("size");
    let mut b = a.clone();
    b.data_mut()[0] = 0.25;
    let mut g = Image::new(2, 1);
    l1_vjp(&a, &b, 6.0, &mut g);
    assert_eq!(g.data(), &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0], "sign(0) = 0");
}

#[test]
fn l2_vjp_matches_fd_and_dual() {
    let mut rng = SplitMix64::new(12);
    for (w, h) in SIZES {
        let (a, b) = (random_image(w, h, &mut rng), random_image(w, h, &mut rng));
        check("l2", l2, l2, l2_vjp, &a, &b, GradCheck::new(1e-11, 1e-8));
    }
}

#[test]
fn psnr_vjp_matches_fd_and_dual() {
    let mut rng = SplitMix64::new(13);
    for (w, h) in SIZES {
        let a = random_image(w, h, &mut rng);
        let b = perturbed(&a, 0.1, &mut rng);
        check(
            "psnr",
            psnr,
            psnr,
            psnr_vjp,
            &a,
            &b,
            GradCheck::new(1e-8, 1e-7),
        );
    }
    let a = random_image(3, 2, &mut rng);
    let mut g = Image::new(3, 2);
    psnr_vjp(&a, &a, 1.0, &mut g);
    assert!(g.data().iter().all(|&x| x == 0.0), "nothing added at a = b");
}

#[test]
fn ssim_vjp_matches_fd_and_dual() {
    let mut rng = SplitMix64::new(14);
    for (w, h) in SIZES {
        let a = random_image(w, h, &mut rng);
        let b = perturbed(&a, 0.1, &mut rng);
        check(
            "ssim",
            ssim,
            ssim,
            ssim_vjp,
            &a,
            &b,
            GradCheck::new(1e-10, 1e-7),
        );
        let b = random_image(w, h, &mut rng);
        check(
            "ssim",
            ssim,
            ssim,
            ssim_vjp,
            &a,
            &b,
            GradCheck::new(1e-10, 1e-7),
        );
    }
}

#[test]
fn d_ssim_vjp_matches_fd_and_dual() {
    let mut rng = SplitMix64::new(15);
    for (w, h) in SIZES {
        let a = random_image(w, h, &mut rng);
        let b = perturbed(&a, 0.05, &mut rng);
        check(
            "d_ssim",
            d_ssim,
            d_ssim,
            d_ssim_vjp,
            &a,
            &b,
            GradCheck::new(1e-10, 1e-7),
        );
    }
}

fn photometric(a: &Image<f64>, b: &Image<f64>) -> f64 {
    photometric_loss(&mut SsimWorkspace::new(), a, b, 0.2, Par::Seq).total
}
fn photometric_dual(a: &Image<Dual<f64>>, b: &Image<Dual<f64>>) -> Dual<f64> {
    photometric_loss(
        &mut SsimWorkspace::new(),
        a,
        b,
        Dual::constant(0.2),
        Par::Seq,
    )
    .total
}
fn photometric_vjp(a: &Image<f64>, b: &Image<f64>, g: f64, d_a: &mut Image<f64>) {
    photometric_loss_and_grad(&mut SsimWorkspace::new(), a, b, 0.2, g, d_a, Par::Seq);
}

#[test]
fn photometric_loss_vjp_matches_fd_and_dual() {
    let mut rng = SplitMix64::new(16);
    for (w, h) in SIZES {
        let a = random_image(w, h, &mut rng);
        // Offsets of ±0.2 keep L1 away from its kinks.
        let data = a
            .data()
            .iter()
            .map(|&x| if x > 0.5 { x - 0.2 } else { x + 0.2 })
            .collect();
        let b = perturbed(&Image::from_vec(w, h, data).expect("size"), 0.01, &mut rng);
        let ok = a
            .data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| (x - y).abs() > 1e-3);
        assert!(ok, "test images must avoid the L1 kink");
        check(
            "photo",
            photometric,
            photometric_dual,
            photometric_vjp,
            &a,
            &b,
            GradCheck::new(1e-10, 1e-7),
        );
    }
}

#[test]
fn photometric_loss_terms_add_up() {
    let mut rng = SplitMix64::new(17);
    let a = random_image(23, 19, &mut rng);
    let b = perturbed(&a, 0.1, &mut rng);
    let mut ws = SsimWorkspace::new();
    let mut g = Image::new(23, 19);
    let p = photometric_loss_and_grad(&mut ws, &a, &b, 0.3, 1.0, &mut g, Par::Seq);
    assert_eq!(p.l1.to_bits(), l1(&a, &b).to_bits(), "L1 term");
    assert_eq!(p.ssim.to_bits(), ssim(&a, &b).to_bits(), "SSIM term");
    assert!(
        (p.total - (0.7 * p.l1 + 0.3 * (1.0 - p.ssim))).abs() < 1e-15,
        "total"
    );
    assert_eq!(
        p,
        photometric_loss(&mut ws, &a, &b, 0.3, Par::Seq),
        "value without gradient"
    );
}
