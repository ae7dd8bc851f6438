//! Makes `data/toys-mv-mini`, the small multi-view scene shipped in the repository, from the
//! project's `toys-mv` scene (N3DV layout, 10 cameras × 30 frames of 360×270):
//!
//! - cameras `cam00` (the test camera), `cam02`, `cam04`, `cam06`, `cam08`;
//! - every third frame (0000, 0003, …, 0027: 10 frames) under its original name, with the
//!   frames' times in `times.txt` (`k / 29` for original frame `k`);
//! - images box-downscaled by 3 to 120×90 (the mean of each 3×3 block, quantised to 8 bits);
//! - `poses_bounds.npy` for the kept cameras with `H`, `W` and the focal length divided by 3;
//! - `points3d.ply` copied unchanged;
//! - `meta.json`: what was taken, and the generator's own OpenGL camera-to-world matrices of
//!   the kept cameras (copied from the source's `meta.json`), which the tests compare with
//!   the cameras the loader derives from `poses_bounds.npy`.
//!
//! ```text
//! cargo run --release -p evogs-cli --example make_mv_mini -- SOURCE/toys-mv data/toys-mv-mini
//! ```

use evogs::data::image_io::{downscale, load_png_rgb, save_png};
use evogs::data::n3dv::{LlffPose, read_poses, write_poses};
use std::path::{Path, PathBuf};

const CAMERAS: [usize; 5] = [0, 2, 4, 6, 8];
const FRAME_STEP: usize = 3;
const FRAMES: usize = 10;
const FACTOR: usize = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    let [src, dst] = args.as_slice() else {
        return Err("usage: make_mv_mini SOURCE_TOYS_MV DESTINATION".into());
    };
    let poses = read_poses(&src.join("poses_bounds.npy"))?;
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(src.join("meta.json"))?)?;
    let total_frames = meta["args"]["frames"]
        .as_u64()
        .ok_or("meta.json: no args.frames")?;
    std::fs::create_dir_all(dst)?;
    let mut kept = Vec::new();
    let mut c2w = Vec::new();
    for &c in &CAMERAS {
        let p = &poses[c];
        let f = FACTOR as f64;
        let hwf = [p.height() / f, p.width() / f, p.focal() / f];
        kept.push(LlffPose::from_c2w_opengl(p.c2w_opengl(), hwf, p.bounds));
        c2w.push(meta["camera"]["c2w_opengl"][c].clone());
        let name = format!("cam{c:02}");
        let out = dst.join(&name).join("images");
        std::fs::create_dir_all(&out)?;
        for k in 0..FRAMES {
            let file = format!("{:04}.png", k * FRAME_STEP);
            let img = load_png_rgb(&src.join(&name).join("images").join(&file), [1.0; 3])?;
            save_png(&downscale(&img, FACTOR), &out.join(&file))?;
        }
    }
    write_poses(&dst.join("poses_bounds.npy"), &kept)?;
    let times: String = (0..FRAMES)
        .map(|k| format!("{}\n", (k * FRAME_STEP) as f64 / (total_frames - 1) as f64))
        .collect();
    std::fs::write(dst.join("times.txt"), times)?;
    std::fs::copy(src.join("points3d.ply"), dst.join("points3d.ply"))?;
    let mini = serde_json::json!({
        "source": "toys-mv (the project's shared multi-view scene)",
        "made_by": "cargo run --release -p evogs-cli --example make_mv_mini",
        "cameras": CAMERAS.iter().map(|c| format!("cam{c:02}")).collect::<Vec<_>>(),
        "frames": (0..FRAMES).map(|k| k * FRAME_STEP).collect::<Vec<_>>(),
        "source_frames": total_frames,
        "downscale": FACTOR,
        "width": 360 / FACTOR,
        "height": 270 / FACTOR,
        "c2w_opengl": c2w,
        "world_up": meta["world"]["up"].clone(),
    });
    std::fs::write(
        dst.join("meta.json"),
        serde_json::to_string_pretty(&mini)? + "\n",
    )?;
    println!("wrote {}", Path::new(dst).display());
    Ok(())
}
