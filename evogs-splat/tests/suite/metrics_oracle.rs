//! Every case of the metrics reference file (own float64 torch code for the 3DGS SSIM,
//! cross-checked with `scipy.ndimage.correlate`; gradients by torch autograd): MSE, PSNR,
//! SSIM, the SSIM map and d SSIM / d img1, in f64, plus f32 agreement.
//!
//! Run with `--nocapture` to see the worst errors per quantity.

use evogs_math::Par;
use evogs_splat::Image;
use evogs_splat::metrics::{mse, psnr};
use evogs_splat::ssim::SsimWorkspace;
use serde_json::Value;

/// Absolute tolerance on MSE, PSNR, SSIM and the map (values of order 1; PSNR ~ 10–40).
const TOL: f64 = 1e-12;
/// Tolerance on the gradient, relative to the largest reference entry of the case
/// (entries are ~1/N ≈ 1e-4, so an absolute 1e-12 would say little).
const TOL_GRAD_REL: f64 = 1e-12;
/// Absolute tolerance on the gradient entries.
const TOL_GRAD_ABS: f64 = 1e-15;

fn load() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/oracle/metrics_shared_cases.json"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {path}: {e}"));
    serde_json::from_str(&text).expect("valid JSON")
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

/// An `[H][W][3]` array as an image (the layouts coincide: row-major, interleaved).
fn image(v: &Value) -> Image<f64> {
    let rows = v.as_array().expect("rows");
    let h = rows.len();
    let w = rows[0].as_array().expect("columns").len();
    let mut data = Vec::with_capacity(h * w * 3);
    for row in rows {
        for px in row.as_array().expect("columns") {
            let px = px.as_array().expect("channels");
            assert_eq!(px.len(), 3, "three channels");
            data.extend(px.iter().map(f));
        }
    }
    Image::from_vec(w, h, data).expect("consistent shape")
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "lengths differ");
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Tracks the worst error per quantity and prints the table at the end.
#[derive(Default)]
struct Worst(Vec<(&'static str, f64, f64)>);

impl Worst {
    fn record(&mut self, what: &'static str, err: f64, tol: f64, case: &str) {
        assert!(
            err <= tol,
            "{what} off by {err:.3e} (tolerance {tol:.1e}) in case {case}"
        );
        match self.0.iter_mut().find(|(w, _, _)| *w == what) {
            Some((_, e, _)) => *e = e.max(err),
            None => self.0.push((what, err, tol)),
        }
    }

    fn print(&self, title: &str) {
        println!("{title}");
        for (what, err, tol) in &self.0 {
            println!("  {what:<40} worst {err:.3e}  (tolerance {tol:.1e})");
        }
    }
}

#[test]
fn f64_matches_every_reference_case() {
    let data = load();
    let cases = data["cases"].as_array().expect("cases");
    assert!(!cases.is_empty(), "reference file has cases");
    let mut ws = SsimWorkspace::<f64>::new();
    let mut worst = Worst::default();
    for c in cases {
        let name = c["name"].as_str().expect("name");
        let (a, b) = (image(&c["img1"]), image(&c["img2"]));
        let shape = c["shape_hwc"].as_array().expect("shape");
        let dim = |i: usize| shape[i].as_u64().expect("integer");
        assert_eq!(dim(0), a.height() as u64, "height of {name}");
        assert_eq!(dim(1), a.width() as u64, "width of {name}");
        assert_eq!(dim(2), 3, "channels of {name}");

        worst.record("mse (abs)", (mse(&a, &b) - f(&c["mse"])).abs(), TOL, name);
        worst.record(
            "psnr (abs, dB)",
            (psnr(&a, &b) - f(&c["psnr"])).abs(),
            TOL,
            name,
        );

        let mut map = Image::new(a.width(), a.height());
        let s_map = ws.ssim_map(&a, &b, &mut map, Par::Seq);
        let s = ws.ssim(&a, &b, Par::Seq);
        assert_eq!(
            s.to_bits(),
            s_map.to_bits(),
            "ssim and ssim_map agree bitwise"
        );
        worst.record("ssim_3dgs (abs)", (s - f(&c["ssim_3dgs"])).abs(), TOL, name);
        let ref_map = image(&c["ssim_3dgs_map"]);
        worst.record(
            "ssim_3dgs_map (max abs)",
            max_abs_diff(map.data(), ref_map.data()),
            TOL,
            name,
        );

        let mut grad = Image::new(a.width(), a.height());
        let s_grad = ws.ssim_and_grad(&a, &b, 1.0, &mut grad, Par::Seq);
        assert_eq!(
            s.to_bits(),
            s_grad.to_bits(),
            "ssim and ssim_and_grad agree bitwise"
        );
        let ref_grad = image(&c["grad_ssim_3dgs_wrt_img1"]);
        let err = max_abs_diff(grad.data(), ref_grad.data());
        worst.record("grad_ssim_3dgs_wrt_img1 (max abs)", err, TOL_GRAD_ABS, name);
        worst.record(
            "grad_ssim_3dgs_wrt_img1 (max abs / max|ref|)",
            err / max_abs(ref_grad.data()),
            TOL_GRAD_REL,
            name,
        );
    }
    worst.print("metrics oracle, f64: worst errors over all cases");
}

#[test]
fn f32_agrees_with_the_reference() {
    let data = load();
    let mut ws = SsimWorkspace::<f32>::new();
    let mut worst = Worst::default();
    for c in data["cases"].as_array().expect("cases") {
        let name = c["name"].as_str().expect("name");
        let (a, b) = (
            image(&c["img1"]).cast::<f32>(),
            image(&c["img2"]).cast::<f32>(),
        );
        worst.record(
            "f32 mse (rel)",
            (f64::from(mse(&a, &b)) / f(&c["mse"]) - 1.0).abs(),
            1e-6,
            name,
        );
        worst.record(
            "f32 psnr (abs, dB)",
            (f64::from(psnr(&a, &b)) - f(&c["psnr"])).abs(),
            1e-5,
            name,
        );
        let mut map = Image::new(a.width(), a.height());
        let s = ws.ssim_map(&a, &b, &mut map, Par::Seq);
        worst.record(
            "f32 ssim_3dgs (abs)",
            (f64::from(s) - f(&c["ssim_3dgs"])).abs(),
            1e-5,
            name,
        );
        let map64 = map.cast::<f64>();
        let ref_map = image(&c["ssim_3dgs_map"]);
        worst.record(
            "f32 ssim_3dgs_map (max abs)",
            max_abs_diff(map64.data(), ref_map.data()),
            1e-4,
            name,
        );
        let mut grad = Image::new(a.width(), a.height());
        ws.ssim_and_grad(&a, &b, 1.0, &mut grad, Par::Seq);
        let ref_grad = image(&c["grad_ssim_3dgs_wrt_img1"]);
        let err = max_abs_diff(grad.cast::<f64>().data(), ref_grad.data());
        worst.record(
            "f32 grad (max abs / max|ref|)",
            err / max_abs(ref_grad.data()),
            1e-3,
            name,
        );
    }
    worst.print("metrics oracle, f32: worst errors over all cases");
}
