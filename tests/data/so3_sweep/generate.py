#!/usr/bin/env python3
"""Generate the SO(3) accuracy sweep reference (so3_sweep.json) with mpmath at 50 digits.

Rotation vectors phi (exact f64 values) along three fixed axes with angles log-spaced over
1e-12..1e-3, a few moderate angles, the coefficient-branch thresholds (theta^2 = 1e-2 and 1)
at +-1e-9 relative, pi - 1e-12..pi - 1e-3, and the f64 value of pi. For each: the quaternion
exp (cos(t/2), sin(t/2)/t phi), the Rodrigues matrix, Jl, Jr, their inverses, and the scalar
coefficients, evaluated at 50 digits from the exact binary value of phi, then rounded to f64.

Usage: python3 generate.py > so3_sweep.json   (needs mpmath; mpmath 1.3.0 was used)
"""
import json
import mpmath as mp

mp.mp.dps = 50

AXES = [(0.6, -0.48, 0.64), (-0.36, 0.8, 0.48), (1.0, 0.0, 0.0)]


def angles():
    out = []
    for k in range(10):
        out.append(10.0 ** (-12 + k))  # 1e-12 .. 1e-3
    out += [1e-2, 0.03, 0.1 * (1 - 1e-9), 0.1 * (1 + 1e-9), 0.5, 1 - 1e-9, 1 + 1e-9, 2.0, 2.9]
    pi = float(mp.pi)
    for k in range(10):
        out.append(pi - 10.0 ** (-12 + k))
    out.append(pi)
    return out


def hat(v):
    return mp.matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def tolist(m):
    return [[float(m[i, j]) for j in range(3)] for i in range(3)]


def main():
    cases = []
    for ax in AXES:
        n = mp.sqrt(sum(mp.mpf(a) ** 2 for a in ax))
        for ang in angles():
            # The exact f64 rotation vector; everything below is computed from these bits.
            phi = [float(mp.mpf(a) / n * ang) for a in ax]
            p = [mp.mpf(x) for x in phi]
            t2 = sum(x * x for x in p)
            t = mp.sqrt(t2)
            K = hat(p)
            K2 = K * K
            I = mp.eye(3)
            sinc = mp.sin(t) / t
            A = (1 - mp.cos(t)) / t2
            B = (t - mp.sin(t)) / (t2 * t)
            D = 1 / t2 - mp.cot(t / 2) / (2 * t)
            s = mp.sin(t / 2) / t
            cases.append({
                "rotvec": phi,
                "theta": float(t),
                "quat_wxyz": [float(mp.cos(t / 2))] + [float(s * x) for x in p],
                "matrix": tolist(I + sinc * K + A * K2),
                "Jl": tolist(I + A * K + B * K2),
                "Jr": tolist(I - A * K + B * K2),
                "Jl_inv": tolist(I - K / 2 + D * K2),
                "Jr_inv": tolist(I + K / 2 + D * K2),
                "coeffs": {"sinc": float(sinc), "A": float(A), "B": float(B), "D": float(D),
                           "cos_half": float(mp.cos(t / 2))},
            })
    json.dump({"generator": "generate.py, mpmath %s, 50 digits" % mp.__version__, "cases": cases},
              __import__("sys").stdout, indent=1)


main()
