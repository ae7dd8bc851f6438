#!/usr/bin/env python3
"""Which body of the `toys` scene the test error comes from (the README's per-body figures).

Reads the test frames a run rendered at the test cameras and times,

    evogs render --run RUN --out DIR --camera test --times 0.0375:0.9875:20

compares them with the test images (RGBA composited on white), and splits each frame's squared
error by body: a disc around the projection of each rigid body's true centre (from the scene's
`meta.json`), of radius (body extent + 0.04) * focal / depth. The discs of different bodies
may overlap, so the shares need not sum to 100 %.

Given a second render folder (`--other`, e.g. a run handed the true motion), it also reports the
mean test PSNR the first run would have if the pixels of one body's disc had the second run's
error instead: how much that body costs the first run against the second.

Usage (numpy and Pillow needed):

    python3 tools/body_error.py DIR --data TOYS [--other DIR2] [--meta tools/data/toys-meta.json]

TOYS is the full `toys` dataset the run was trained on (its `test/` images and
`transforms_test.json`); it is not shipped in the repository.
"""

import argparse
import json
import os

import numpy as np
from PIL import Image

BODIES = ("cube", "torus", "ball")


def extents(meta):
    o = meta["objects"]
    return {
        "cube": o["cube"]["half_size"] * 3**0.5,
        "torus": o["torus"]["major_radius"] + o["torus"]["minor_radius"],
        "ball": o["ball"]["radius"],
    }


def disc(centre, cam_to_world, focal, pixels, extent):
    """Pixels (centres `pixels` = (xx, yy)) near the projection of a body centre (OpenGL camera)."""
    cam_from_world = np.linalg.inv(np.array(cam_to_world))
    p = cam_from_world[:3, :3] @ centre + cam_from_world[:3, 3]
    depth = -p[2]
    xx, yy = pixels
    h, w = xx.shape
    u, v = w / 2 + focal * p[0] / depth, h / 2 - focal * p[1] / depth
    r = (extent + 0.04) * focal / depth
    return (xx - u) ** 2 + (yy - v) ** 2 < r * r


def test_image(data, i):
    """Test image `i` composited on white, in [0, 1]."""
    gt = np.asarray(Image.open(os.path.join(data, "test", "r_%03d.png" % i)).convert("RGBA"))
    gt = gt.astype(float) / 255
    return gt[..., :3] * gt[..., 3:] + (1 - gt[..., 3:])


def squared_error(rgb, folder, i):
    """Per-pixel squared error (mean over channels) of rendered frame `i` against `rgb`."""
    pred = np.asarray(Image.open(os.path.join(folder, "frame_%04d.png" % i)).convert("RGB"))
    return ((pred.astype(float) / 255 - rgb) ** 2).mean(-1)


def psnr(err):
    return -10 * np.log10(err.mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--other")
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--meta", default=os.path.join(here, "data", "toys-meta.json"))
    ap.add_argument("--data", required=True, help="the toys dataset folder")
    args = ap.parse_args()
    meta = json.load(open(args.meta))
    transforms = json.load(open(os.path.join(args.data, "transforms_test.json")))
    cams = transforms["frames"]
    ext = extents(meta)
    swapped = {b: [] for b in BODIES}
    plain = []
    pixels = None
    for i in range(len(cams)):
        rgb = test_image(args.data, i)
        err = squared_error(rgb, args.dir, i)
        if pixels is None:
            h, w = err.shape
            yy, xx = np.mgrid[0:h, 0:w] + 0.5
            pixels = (xx, yy)
            focal = 0.5 * w / np.tan(0.5 * transforms["camera_angle_x"])
        objects = meta["frames"]["test"][i]["objects"]
        masks = {
            b: disc(np.array(objects[b])[:3, 3], cams[i]["transform_matrix"], focal, pixels, ext[b])
            for b in BODIES
        }
        plain.append(psnr(err))
        row = "frame %2d  t = %.4f  PSNR %5.2f" % (i, cams[i]["time"], plain[-1])
        total = err.sum()
        row += "".join("  %s %3.0f %%" % (b, 100 * err[m].sum() / total) for b, m in masks.items())
        if args.other:
            other = squared_error(rgb, args.other, i)
            row += "  | other %5.2f" % psnr(other)
            for b, m in masks.items():
                mixed = err.copy()
                mixed[m] = other[m]
                swapped[b].append(psnr(mixed))
        print(row)
    print("mean PSNR %.2f dB" % np.mean(plain))
    if args.other:
        for b in BODIES:
            print("with the %s's disc from --other: %.2f dB" % (b, np.mean(swapped[b])))


if __name__ == "__main__":
    main()
