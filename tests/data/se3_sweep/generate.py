#!/usr/bin/env python3
"""Generate the SE(3) accuracy sweep (se3_sweep.json) with mpmath at 60 digits.

The cases follow the schema of the shared oracle file se3_shared_cases.json (SCHEMA.md,
"se3_shared_cases.json") so that the same checks (and `evogs verify`) read both. Tangents
xi = (rho, phi) (translation part first) are exact f64 values; rotation angles: 0, 1e-12 ..
1e-2 (tiny), the branch thresholds of the coefficient series (theta^2 = 1e-2, 1 and 2.25, at
+-1e-9 relative), moderate, pi - 1e-2 .. pi - 1e-8 (near_pi), pi + 1e-6 .. 5.5 (beyond_pi), a
pure translation and a large translation. Everything is computed from the exact binary
inputs without any closed form: T = expm(hat(xi)) by mpmath, Jl = sum ad(xi)^n/(n+1)!,
Jr = sum (-ad(xi))^n/(n+1)!, the inverses by mpmath matrix inversion, Ad from T, then rounded
to f64. log_of_matrix (= xi) is stored where the angle is below pi - 1e-6, as in the shared
file.

Usage: python3 generate.py > se3_sweep.json   (needs mpmath; mpmath 1.3.0 was used)
"""
import json
import random
import sys

import mpmath as mp

mp.mp.dps = 60

AXES = [(0.6, -0.48, 0.64), (-0.36, 0.8, 0.48), (0.0, 0.0, 1.0)]
RHOS = [(0.7, -1.3, 0.4), (-2.0, 0.5, 1.5), (0.25, 0.0, -0.75)]


def kinds():
    pi = float(mp.pi)
    out = [("zero", 0.0)]
    out += [("tiny_rotation", 10.0 ** e) for e in (-12, -10, -8, -6, -4, -3, -2)]
    for thr in (0.1, 1.0, 1.5):
        out += [("threshold", thr * (1 - 1e-9)), ("threshold", thr * (1 + 1e-9))]
    out += [("moderate", a) for a in (0.3, 0.9, 2.0, 2.9)]
    out += [("near_pi", pi - 10.0 ** e) for e in (-2, -4, -6, -8)]
    out += [("beyond_pi", a) for a in (pi + 1e-6, 3.5, 4.0, 5.5)]
    return out


def hat3(v):
    return mp.matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def blocks(a, b, c, d):
    m = mp.zeros(6, 6)
    for i in range(3):
        for j in range(3):
            m[i, j], m[i, j + 3], m[i + 3, j], m[i + 3, j + 3] = a[i, j], b[i, j], c[i, j], d[i, j]
    return m


def hat(xi):
    m = mp.zeros(4, 4)
    k = hat3(xi[3:])
    for i in range(3):
        for j in range(3):
            m[i, j] = k[i, j]
        m[i, 3] = xi[i]
    return m


def ad(xi):
    p = hat3(xi[3:])
    return blocks(p, hat3(xi[:3]), mp.zeros(3, 3), p)


def series(a):
    """sum a^n/(n+1)! to convergence."""
    term = mp.eye(6)
    total = mp.eye(6)
    n = 1
    while True:
        term = term * a / (n + 1)
        total += term
        if mp.mnorm(term, 1) < mp.mpf(10) ** (-mp.mp.dps + 5):
            return total
        n += 1


def tolist(m):
    return [[float(m[i, j]) for j in range(m.cols)] for i in range(m.rows)]


def quat_of(r):
    # The rotation's quaternion with w >= 0 (Shepperd at 60 digits).
    tr = r[0, 0] + r[1, 1] + r[2, 2]
    w = mp.sqrt(max(1 + tr, 0)) / 2
    if w > mp.mpf("0.1"):
        return [w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w),
                (r[1, 0] - r[0, 1]) / (4 * w)]
    i = max(range(3), key=lambda k: r[k, k])
    j, k = (i + 1) % 3, (i + 2) % 3
    x = mp.sqrt(1 + r[i, i] - r[j, j] - r[k, k]) / 2
    q = [None] * 4
    q[0] = (r[k, j] - r[j, k]) / (4 * x)
    q[1 + i] = x
    q[1 + j] = (r[j, i] + r[i, j]) / (4 * x)
    q[1 + k] = (r[k, i] + r[i, k]) / (4 * x)
    if q[0] < 0:
        q = [-c for c in q]
    return q


def case(kind, angle, axis, rho, rng):
    n = mp.sqrt(sum(mp.mpf(a) ** 2 for a in axis))
    phi = [float(mp.mpf(a) / n * angle) for a in axis]
    xi_f = list(rho) + phi
    xi = [mp.mpf(x) for x in xi_f]
    t = mp.expm(hat(xi))
    r = t[:3, :3]
    tr = t[:3, 3]
    other = [round(rng.uniform(-1.5, 1.5), 6) for _ in range(6)]
    point = [round(rng.uniform(-2, 2), 6) for _ in range(3)]
    p = mp.matrix([mp.mpf(x) for x in point])
    a = ad(xi)
    jl = series(a)
    jr = series(-a)
    c = {
        "kind": kind,
        "xi": xi_f,
        "angle": float(mp.sqrt(sum(x * x for x in xi[3:]))),
        "matrix": tolist(t),
        "quat_wxyz": [float(v) for v in quat_of(r)],
        "translation": [float(tr[i]) for i in range(3)],
        "Jl": tolist(jl),
        "Jr": tolist(jr),
        "Jl_inv": tolist(mp.inverse(jl)),
        "Jr_inv": tolist(mp.inverse(jr)),
        "Ad": tolist(blocks(r, hat3(tr) * r, mp.zeros(3, 3), r)),
        "ad": tolist(a),
        "inverse": tolist(mp.inverse(t)),
        "other_xi": other,
        "compose_with_other": tolist(t * mp.expm(hat([mp.mpf(x) for x in other]))),
        "point": point,
        "act_on_point": [float(v) for v in (r * p + tr)],
    }
    if angle < float(mp.pi) - 1e-6:
        c["log_of_matrix"] = xi_f
    return c


def main():
    rng = random.Random(20261126)
    cases = []
    for i, (kind, angle) in enumerate(kinds()):
        cases.append(case(kind, angle, AXES[i % 3], RHOS[i % 3], rng))
    cases.append(case("pure_translation", 0.0, AXES[0], (3.0, -1.0, 2.0), rng))
    cases.append(case("large_translation", 1.2, AXES[1], (120.0, -75.0, 40.0), rng))
    json.dump({
        "schema_version": 1,
        "generator_versions": {"mpmath": mp.__version__, "script": "generate.py, 60 digits"},
        "kind": "se3",
        "convention": "as se3_shared_cases.json: xi = (rho, phi), translation part first",
        "cases": cases,
    }, sys.stdout, indent=1)


main()
