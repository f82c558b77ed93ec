#!/usr/bin/env python3
"""RMSE of images against the mean of two independent references, with the
references' own noise taken out.

    scripts/error-against-two-references.py REF_A PASSES_A REF_B PASSES_B IMAGE... \\
        [--window Y0:Y1,X0:X1] [--light LUMINANCE]

The references are two renders of the same scene by one method with
different seeds (BENCHMARKS.md uses VCM under a time budget), weighed by
their passes. Their noise falls as one over the passes, so the variance of
their difference is s_a^2 (1 + PASSES_A / PASSES_B), where s_a^2 is REF_A's
noise; the mean's is s_a^2 PASSES_A / (PASSES_A + PASSES_B). An image's
squared error against the mean, less that, is its own error.

Printed per image, over the whole image, without the pixels that see a
light (mean of RGB in the reference above LUMINANCE, 20 by default) and two
pixels around them, and in an optional window: RMSE, and in brackets RMSE
less the reference's noise.

Needs numpy and OpenEXR (pip install numpy OpenEXR).
"""
import argparse

import numpy as np
import OpenEXR


def load(path):
    channels = OpenEXR.File(path).channels()
    if "RGB" in channels:
        return np.asarray(channels["RGB"].pixels, dtype=np.float64)
    return np.stack([np.asarray(channels[c].pixels, dtype=np.float64) for c in "RGB"], -1)


def grown(mask, pixels):
    """The mask and every pixel within `pixels` steps of it (8-connected)."""
    out = mask.copy()
    h, w = mask.shape
    for _ in range(pixels):
        padded = np.pad(out, 1)
        out = np.zeros_like(out)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                out |= padded[dy : dy + h, dx : dx + w]
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("ref_a")
    parser.add_argument("passes_a", type=float)
    parser.add_argument("ref_b")
    parser.add_argument("passes_b", type=float)
    parser.add_argument("images", nargs="+")
    parser.add_argument("--window", help="Y0:Y1,X0:X1, rows and columns (end excluded)")
    parser.add_argument("--light", type=float, default=20.0)
    args = parser.parse_args()

    a, b = load(args.ref_a), load(args.ref_b)
    na, nb = args.passes_a, args.passes_b
    ref = (na * a + nb * b) / (na + nb)
    difference2 = ((a - b) ** 2).mean(-1)
    masks = {"whole": np.ones(ref.shape[:2], bool), "without lights": ~grown(ref.mean(-1) > args.light, 2)}
    if args.window:
        (y0, y1), (x0, x1) = (map(int, part.split(":")) for part in args.window.split(","))
        window = np.zeros(ref.shape[:2], bool)
        window[y0:y1, x0:x1] = True
        masks["window"] = window

    def reference_noise2(mask):
        return difference2[mask].mean() / (1 + na / nb) * na / (na + nb)

    print("the reference's own noise: " + ", ".join(f"{k} {np.sqrt(reference_noise2(m)):.4f}" for k, m in masks.items()))
    for path in args.images:
        error2 = ((load(path) - ref) ** 2).mean(-1)
        parts = []
        for name, mask in masks.items():
            e2 = error2[mask].mean()
            parts.append(f"{name} {np.sqrt(e2):.4f} ({np.sqrt(max(e2 - reference_noise2(mask), 0.0)):.4f})")
        print(f"{path}: " + "; ".join(parts))


if __name__ == "__main__":
    main()
