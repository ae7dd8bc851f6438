#!/usr/bin/env python3
"""How much does the colour of one material point on the toys cube change across views?

A Gaussian keeps one colour (SH over the view direction) for all times, but the toys cube
turns under fixed lights, so its faces brighten and darken. This samples the ground-truth
training images at 3x3 points on each face of the cube, posed by its true motion
(meta.json), in every view where the face is turned towards the camera (occlusion by other
objects is ignored), and reports the RMS spread of each point's colour across views: around
its mean, and around a per-point least-squares SH degree-3 fit over the view direction. That
spread is an error floor of a perfectly tracked fixed-colour model on the cube. It also
reports the cube's mean image coverage (the convex hull of its projected corners).

    python3 tools/shading_floor.py [--data DIR] [--meta tools/data/toys-meta.json]

DIR: a toys scene in D-NeRF format (default: data/toys-mini, shipped with evogs; the README's
figures are from the full 400x400, 150-view scene, passed with --data).
"""
import argparse
import json
import math
import os

import numpy as np
from PIL import Image


def rot(axis, ang):
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(ang) * k + (1 - math.cos(ang)) * k @ k


def sh3(d):
    x, y, z = d
    return np.array([1, y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y,
                     y * (3 * x * x - y * y), x * y * z, y * (5 * z * z - 1),
                     z * (5 * z * z - 3), x * (5 * z * z - 1), z * (x * x - y * y),
                     x * (x * x - 3 * y * y)])


def hull_area(pts):
    pts = sorted(map(tuple, pts))
    def half(p):
        h = []
        for q in p:
            while len(h) >= 2 and (h[-1][0] - h[-2][0]) * (q[1] - h[-2][1]) - (h[-1][1] - h[-2][1]) * (q[0] - h[-2][0]) <= 0:
                h.pop()
            h.append(q)
        return h
    h = half(pts)[:-1] + half(pts[::-1])[:-1]
    return 0.5 * abs(sum(h[i][0] * h[i - 1][1] - h[i - 1][0] * h[i][1] for i in range(len(h))))


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.path.join(here, "..", "data", "toys-mini"))
    ap.add_argument("--meta", default=os.path.join(here, "data", "toys-meta.json"))
    a = ap.parse_args()
    cube = json.load(open(a.meta))["objects"]["cube"]
    c, h = np.array(cube["centre"]), cube["half_size"]
    tr = json.load(open(os.path.join(a.data, "transforms_train.json")))
    obs = {}  # (axis, sign) -> list of (colours 9x3, view direction)
    cover = []
    for fr in tr["frames"]:
        t = fr["time"]
        r = rot(cube["axis"], 2 * math.pi * cube["rev_per_unit_time"] * t) @ rot([1, 1, 0], 0.5)
        m = np.array(fr["transform_matrix"], float)
        cam, w2c = m[:3, 3], np.linalg.inv(m)
        path = os.path.join(a.data, fr["file_path"].lstrip("./") + ".png")
        img = np.asarray(Image.open(path).convert("RGBA"), float) / 255
        hgt, wid = img.shape[:2]
        f = 0.5 * wid / math.tan(0.5 * tr["camera_angle_x"])

        def project(q):
            x = (w2c @ np.append(q, 1))[:3]  # OpenGL camera: looks down -z
            return f * x[0] / -x[2] + 0.5 * wid, -f * x[1] / -x[2] + 0.5 * hgt

        corners = [project(c + r @ (h * (2 * np.array(s) - 1))) for s in np.ndindex(2, 2, 2)]
        cover.append(hull_area(corners) / (wid * hgt))
        for k in range(3):
            for s in (1, -1):
                n = r[:, k] * s
                p = c + h * n
                if n @ (cam - p) <= 0.05 * np.linalg.norm(cam - p):
                    continue
                u, v = r[:, (k + 1) % 3], r[:, (k + 2) % 3]
                cols = []
                for du in (-0.5 * h, 0, 0.5 * h):
                    for dv in (-0.5 * h, 0, 0.5 * h):
                        px, py = project(p + du * u + dv * v)
                        cols.append(img[int(py), int(px), :3])
                d = (p - cam) / np.linalg.norm(p - cam)
                obs.setdefault((k, s), []).append((np.array(cols), d))
    const, fitted, n_obs = [], [], 0
    for rows in obs.values():
        if len(rows) < 40:
            continue
        col = np.stack([r[0] for r in rows])
        basis = np.stack([sh3(r[1]) for r in rows])
        n_obs += len(rows)
        for q in range(9):
            for ch in range(3):
                y = col[:, q, ch]
                coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
                fitted.append(np.mean((basis @ coef - y) ** 2))
                const.append(np.mean((y - y.mean()) ** 2))
    rms_c, rms_f = math.sqrt(np.mean(const)), math.sqrt(np.mean(fitted))
    cov = float(np.mean(cover))
    floor = cov * rms_f ** 2
    print(f"{len(tr['frames'])} views, {n_obs} face observations")
    print(f"colour spread of a cube point across views: {rms_c:.3f} RMS (constant colour), "
          f"{rms_f:.3f} RMS (SH degree 3 over the view direction)")
    print(f"cube coverage {100 * cov:.1f} % of the image: floor MSE {floor:.2e} "
          f"({-10 * math.log10(floor):.1f} dB if it were the only error)")


if __name__ == "__main__":
    main()
