#!/usr/bin/python3
"""Question: how far do the meshes of one run move against a reference run's
(docs/decisions.md, isolated empty slices)? Per mesh file in both folders:
equal geometry, or the symmetric mean and max surface distance (orex_eval's
area-sampled points to the exact triangles, px/mm as written).

usage: isolated_empty_diff.py REF_DIR DIR [DIR ...]"""
import glob
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402
import orex_eval as oe  # noqa: E402

SAMPLES = 200000  # points per surface: the mean's sampling error well under 1 % here


def main():
    ref, dirs = sys.argv[1], sys.argv[2:]
    for path in sorted(glob.glob(os.path.join(ref, "**", "*.ply"), recursive=True)):
        rel = os.path.relpath(path, ref)
        V0, F0, _ = ic.read_ply(path)
        for d in dirs:
            other = os.path.join(d, rel)
            if not os.path.exists(other):
                print("%-40s %-24s missing" % (rel, d))
                continue
            V1, F1, _ = ic.read_ply(other)
            if V0.shape == V1.shape and F0.shape == F1.shape and np.array_equal(V0, V1) and np.array_equal(F0, F1):
                print("%-40s %-24s same" % (rel, os.path.basename(d)))
                continue
            a, b = oe.surface_distances(V0, F0, V1, F1, n=SAMPLES)
            print("%-40s %-24s mean %.4f max %.3f  (tris %d -> %d, area-weighted points moved > 0.1: %.2f %%)" % (
                rel, os.path.basename(d), 0.5 * (a.mean() + b.mean()), max(a.max(), b.max()), len(F0), len(F1),
                50 * ((a > 0.1).mean() + (b > 0.1).mean())))


if __name__ == "__main__":
    main()
