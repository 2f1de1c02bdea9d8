#!/usr/bin/python3
"""Independent expected values for tests/eval/test_image_metrics.cpp (FLIP).

An LDR FLIP written straight from the paper's equations (Andersson et al., HPG 2020) with
NumPy, deliberately unlike eval/src/flip.cpp: direct 2-D kernels (no separable passes),
edge replication by index clamping, float64. It prints the values the C++ test expects:
    /usr/bin/python3 tests/eval/data/flip_reference.py
Needs python3-numpy (installed with python3-matplotlib). The images are the formulas in
pattern_pair() below, which the C++ test repeats.
"""
import math

import numpy as np

PPD = 0.7 * (3840 / 0.7) * math.pi / 180
QC, QF, PC, PT, W = 0.7, 0.5, 0.4, 0.95, 0.082
WHITE = np.array([0.950428545, 1.0, 1.088900371])
RGB2XYZ = np.array([[10135552 / 24577794, 8788810 / 24577794, 4435075 / 24577794],
                    [2613072 / 12288897, 8788810 / 12288897, 887015 / 12288897],
                    [1425312 / 73733382, 8788810 / 73733382, 70074185 / 73733382]])
XYZ2RGB = np.linalg.inv(RGB2XYZ)


def srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def lab_hunt(xyz):
    """xyz: (..., 3) -> Hunt-adjusted L*a*b* (..., 3)."""
    t = xyz / WHITE
    d = 6 / 29
    f = np.where(t > d ** 3, np.cbrt(t), t / (3 * d * d) + 4 / 29)
    l = 116 * f[..., 1] - 16
    a = 500 * (f[..., 0] - f[..., 1])
    b = 200 * (f[..., 1] - f[..., 2])
    return np.stack([l, 0.01 * l * a, 0.01 * l * b], axis=-1)


def hyab(p, q):
    d = p - q
    return np.abs(d[..., 0]) + np.hypot(d[..., 1], d[..., 2])


def cmax():
    g = lab_hunt(RGB2XYZ @ np.array([0.0, 1.0, 0.0]))
    b = lab_hunt(RGB2XYZ @ np.array([0.0, 0.0, 1.0]))
    return hyab(g, b) ** QC


def redistribute(e):
    c = cmax()
    return np.where(e < PC * c, PT / (PC * c) * e, PT + (e - PC * c) / (c - PC * c) * (1 - PT))


def correlate_clamped(plane, kernel):
    """Direct 2-D correlation with the image's edge pixels repeated."""
    h, w = plane.shape
    r = kernel.shape[0] // 2
    out = np.zeros_like(plane)
    for y in range(h):
        for x in range(w):
            ys = np.clip(np.arange(y - r, y + r + 1), 0, h - 1)
            xs = np.clip(np.arange(x - r, x + r + 1), 0, w - 1)
            out[y, x] = np.sum(kernel * plane[np.ix_(ys, xs)])
    return out


def csf_kernel(a1, b1, a2, b2):
    r = math.ceil(3 * math.sqrt(0.04 / (2 * math.pi ** 2)) * PPD)
    i = np.arange(-r, r + 1) / PPD
    z = i[None, :] ** 2 + i[:, None] ** 2
    s = a1 * math.sqrt(math.pi / b1) * np.exp(-math.pi ** 2 * z / b1)
    if a2:
        s = s + a2 * math.sqrt(math.pi / b2) * np.exp(-math.pi ** 2 * z / b2)
    return s / s.sum()


def feature_kernels():
    sd = 0.5 * W * PPD
    r = math.ceil(3 * sd)
    x, y = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1))
    g = np.exp(-(x ** 2 + y ** 2) / (2 * sd * sd))
    out = []
    for k in (-x * g, (x ** 2 / (sd * sd) - 1) * g):
        k = np.where(k < 0, k / -k[k < 0].sum(), k / k[k > 0].sum())
        out.append(k)
    return out  # edge, point (along x; transposed for y)


def flip_map(ref_u8, test_u8):
    """ref_u8, test_u8: (h, w, 3) uint8 -> (h, w) FLIP errors."""
    kernels = [csf_kernel(1, 0.0047, 0, 1), csf_kernel(1, 0.0053, 0, 1),
               csf_kernel(34.1, 0.04, 13.5, 0.025)]
    edge, point = feature_kernels()
    labs, feats = [], []
    for img in (ref_u8, test_u8):
        xyz = srgb_to_linear(img / 255.0) @ RGB2XYZ.T
        t = xyz / WHITE
        opp = [116 * t[..., 1] - 16, 500 * (t[..., 0] - t[..., 1]), 200 * (t[..., 1] - t[..., 2])]
        filt = [correlate_clamped(c, k) for c, k in zip(opp, kernels)]
        yy = (filt[0] + 16) / 116
        xyz_f = np.stack([yy + filt[1] / 500, yy, yy - filt[2] / 200], axis=-1) * WHITE
        rgb = np.clip(xyz_f @ XYZ2RGB.T, 0, 1)
        labs.append(lab_hunt(rgb @ RGB2XYZ.T))
        lum = t[..., 1]
        e = np.hypot(correlate_clamped(lum, edge), correlate_clamped(lum, edge.T))
        p = np.hypot(correlate_clamped(lum, point), correlate_clamped(lum, point.T))
        feats.append((e, p))
    colour = redistribute(hyab(labs[0], labs[1]) ** QC)
    fe = np.maximum(np.abs(feats[0][0] - feats[1][0]), np.abs(feats[0][1] - feats[1][1]))
    feature = (fe / math.sqrt(2)) ** QF
    return colour ** (1 - feature)


def uniform_colour_error(ref_rgb, test_rgb):
    """FLIP of two uniform images: filtering leaves them unchanged, features are zero."""
    labs = [lab_hunt(RGB2XYZ @ srgb_to_linear(np.array(c) / 255.0)) for c in (ref_rgb, test_rgb)]
    return float(redistribute(hyab(labs[0], labs[1]) ** QC))


def pattern_pair(w=24, h=20):
    """The test's pattern images (same formulas in the C++ test)."""
    ref = np.zeros((h, w, 3), np.uint8)
    test = np.zeros((h, w, 3), np.uint8)
    for y in range(h):
        for x in range(w):
            ref[y, x] = (8 * x + 2 * y, 230 if x >= 12 else 40, (7 * x * y) % 256)
            r = 8 * x + 2 * y + (30 if 4 <= x < 10 and 4 <= y < 10 else 0)
            test[y, x] = (r, 230 if x >= 13 else 40, (7 * x * y + 13 * ((x + y) % 3)) % 256)
    return ref, test


if __name__ == "__main__":
    print("uniform (200,50,50) vs (180,70,40): %.10f"
          % uniform_colour_error((200, 50, 50), (180, 70, 40)))
    print("uniform (128,128,128) vs (138,138,138): %.10f"
          % uniform_colour_error((128,) * 3, (138,) * 3))
    ref, test = pattern_pair()
    m = flip_map(ref, test)
    print("pattern 24x20 mean: %.10f" % m.mean())
    print("pattern pixel (6,6): %.10f  (12,3): %.10f  (0,0): %.10f" % (m[6, 6], m[3, 12], m[0, 0]))
