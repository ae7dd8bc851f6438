//! `metrics_*` files: MSE, PSNR, the 3DGS SSIM, its map and its gradient with respect to
//! `img1` (the library's [`SsimWorkspace`]), and scikit-image's SSIM ([`ssim_skimage`]),
//! against own float64 torch code, scipy and scikit-image (SCHEMA.md, "metrics").
//! Tolerance 1e-12 absolute for every quantity (the schema's metrics row).

use super::json::{Malformed, Node, Res};
use super::report::{Row, Rule, Tally};
use evogs_math::Par;
use evogs_splat::Image;
use evogs_splat::metrics::{mse, psnr};
use evogs_splat::ssim::{SsimWorkspace, gaussian_window};

const TOL: Rule = Rule::Abs(1e-12);
/// Half-width of the 11-tap window.
const RADIUS: usize = 5;
const C1: f64 = 0.01 * 0.01;
const C2: f64 = 0.03 * 0.03;

/// Index into `0..n` with scipy's `reflect` boundary (half-sample symmetric:
/// `d c b a | a b c d | d c b a`), for offsets within one image length.
fn reflect(i: isize, n: usize) -> usize {
    let n = isize::try_from(n).unwrap_or(isize::MAX);
    let mut i = i;
    while i < 0 || i >= n {
        i = if i < 0 { -i - 1 } else { 2 * n - i - 1 };
    }
    usize::try_from(i).unwrap_or(0)
}

/// Separable Gaussian filter with reflect padding of one `h × w` channel (rows, then
/// columns, as `scipy.ndimage.gaussian_filter` does).
fn gaussian_reflect(x: &[f64], w: usize, h: usize) -> Vec<f64> {
    let g: [f64; 11] = gaussian_window();
    let mut tmp = vec![0.0; w * h];
    let r = isize::try_from(RADIUS).unwrap_or(5);
    for i in 0..h {
        for j in 0..w {
            let ii = isize::try_from(i).unwrap_or(0);
            tmp[i * w + j] = (0..11)
                .map(|k| g[k] * x[reflect(ii + isize::try_from(k).unwrap_or(0) - r, h) * w + j])
                .sum();
        }
    }
    let mut out = vec![0.0; w * h];
    for i in 0..h {
        for j in 0..w {
            let jj = isize::try_from(j).unwrap_or(0);
            out[i * w + j] = (0..11)
                .map(|k| g[k] * tmp[i * w + reflect(jj + isize::try_from(k).unwrap_or(0) - r, w)])
                .sum();
        }
    }
    out
}

/// scikit-image's `structural_similarity(img1, img2, gaussian_weights=True, sigma=1.5,
/// use_sample_covariance=False, data_range=1.0, channel_axis=-1)`: per channel, the SSIM
/// map with the 11-tap Gaussian window and **reflect** padding, cropped by 5 px on every
/// side and averaged; then the mean over channels.
///
/// # Panics
/// If the images differ in size or are smaller than 11 × 11.
#[must_use]
pub fn ssim_skimage(a: &Image<f64>, b: &Image<f64>) -> f64 {
    assert!(a.same_size(b), "images differ in size");
    let (w, h) = (a.width(), a.height());
    assert!(
        w > 2 * RADIUS && h > 2 * RADIUS,
        "image smaller than the window"
    );
    let mut total = 0.0;
    for ch in 0..3 {
        let x: Vec<f64> = a.data().iter().skip(ch).step_by(3).copied().collect();
        let y: Vec<f64> = b.data().iter().skip(ch).step_by(3).copied().collect();
        let prod =
            |p: &[f64], q: &[f64]| -> Vec<f64> { p.iter().zip(q).map(|(u, v)| u * v).collect() };
        let ux = gaussian_reflect(&x, w, h);
        let uy = gaussian_reflect(&y, w, h);
        let uxx = gaussian_reflect(&prod(&x, &x), w, h);
        let uyy = gaussian_reflect(&prod(&y, &y), w, h);
        let uxy = gaussian_reflect(&prod(&x, &y), w, h);
        let mut sum = 0.0;
        for i in RADIUS..h - RADIUS {
            for j in RADIUS..w - RADIUS {
                let k = i * w + j;
                let (mx, my) = (ux[k], uy[k]);
                let vx = uxx[k] - mx * mx;
                let vy = uyy[k] - my * my;
                let vxy = uxy[k] - mx * my;
                let num = (2.0 * mx * my + C1) * (2.0 * vxy + C2);
                let den = (mx * mx + my * my + C1) * (vx + vy + C2);
                sum += num / den;
            }
        }
        let count = ((h - 2 * RADIUS) * (w - 2 * RADIUS)) as f64;
        total += sum / count;
    }
    total / 3.0
}

/// An `[H][W][3]` array as an image.
fn image(n: &Node<'_>, h: usize, w: usize) -> Res<Image<f64>> {
    let data = n.nums(&[h, w, 3])?;
    Image::from_vec(w, h, data).ok_or_else(|| Malformed {
        path: n.path().to_string(),
        expected: "a non-empty image".to_string(),
    })
}

fn case(t: &mut Tally, c: &Node<'_>, ws: &mut SsimWorkspace<f64>) -> Res<()> {
    let name = c.get("name")?.str()?;
    let shape_node = c.get("shape_hwc")?;
    let shape = shape_node.ints(&[3])?;
    let dims: Vec<usize> = shape
        .iter()
        .map(|&d| usize::try_from(d).unwrap_or(0))
        .collect();
    if dims[2] != 3 || dims[0] == 0 || dims[1] == 0 {
        return Err(Malformed {
            path: shape_node.path().to_string(),
            expected: "[H, W, 3] with H, W > 0".to_string(),
        });
    }
    let (h, w) = (dims[0], dims[1]);
    let a = image(&c.get("img1")?, h, w)?;
    let b = image(&c.get("img2")?, h, w)?;
    let none = |_: usize| String::new();
    let px = move |i: usize| format!("[{}][{}][{}]", i / (3 * w), (i / 3) % w, i % 3);
    let scalar = |t: &mut Tally, key: &str, v: f64| -> Res<()> {
        t.floats(key, TOL, name, &[v], &[c.get(key)?.f64()?], &none);
        Ok(())
    };
    scalar(t, "mse", mse(&a, &b))?;
    scalar(t, "psnr", psnr(&a, &b))?;
    let mut map = Image::new(w, h);
    let s = ws.ssim_map(&a, &b, &mut map, Par::Seq);
    scalar(t, "ssim_3dgs", s)?;
    if w > 2 * RADIUS && h > 2 * RADIUS {
        scalar(t, "ssim_skimage", ssim_skimage(&a, &b))?;
    } else {
        t.fail(
            "ssim_skimage",
            &format!("{name}: image smaller than the 11-px window"),
        );
    }
    t.floats(
        "ssim_3dgs_map",
        TOL,
        name,
        map.data(),
        &c.get("ssim_3dgs_map")?.nums(&[h, w, 3])?,
        &px,
    );
    let mut grad = Image::new(w, h);
    ws.ssim_and_grad(&a, &b, 1.0, &mut grad, Par::Seq);
    t.floats(
        "grad_ssim_3dgs_wrt_img1",
        TOL,
        name,
        grad.data(),
        &c.get("grad_ssim_3dgs_wrt_img1")?.nums(&[h, w, 3])?,
        &px,
    );
    Ok(())
}

/// Recomputes a metrics file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let mut t = Tally::default();
    let mut ws = SsimWorkspace::new();
    let cases = root.get("cases")?.items()?;
    for c in &cases {
        case(&mut t, c, &mut ws)?;
    }
    Ok((cases.len(), t.into_rows()))
}
