#!/usr/bin/env python3
"""A jawbone-scale stack of a real shape, for the speed benchmark (issue 15).

The paper's jawbone is 48 slices of 500x500 at 8:1. This writes the same
scale from a real label: the Whole Frog's skeleton (label 13, branching and
thin), its 136 slices resampled to 48 by nearest slice and padded to 500x500,
as a sparse MetaImage label volume: 1 mm pixels, the kept slices 8 mm apart,
the voxel slices between them empty (so the sparse-axis rule finds them).

usage: real_stack.py FROG_MHD OUT.mha [--label 13] [--slices 48]
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("frog")
    ap.add_argument("out")
    ap.add_argument("--label", type=int, default=13)
    ap.add_argument("--slices", type=int, default=48)
    ap.add_argument("--size", type=int, default=500)
    ap.add_argument("--ratio", type=int, default=8, help="slice spacing over pixel size")
    a = ap.parse_args()
    vol, _ = ic.read_frog(a.frog)
    nz, ny, nx = vol.shape
    keep = np.round(np.linspace(0, nz - 1, a.slices)).astype(int)
    out = np.zeros(((a.slices - 1) * a.ratio + 1, a.size, a.size), np.uint8)
    for i, k in enumerate(keep):
        out[i * a.ratio, :ny, :nx] = (vol[k] == a.label) * a.label
    tmp = a.out + ".tmp"
    with open(tmp, "wb") as f:
        f.write(("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
                 "CompressedData = False\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = 0 0 0\n"
                 "ElementSpacing = 1 1 1\nDimSize = %d %d %d\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n"
                 % (a.size, a.size, out.shape[0])).encode())
        f.write(out.tobytes())
    os.replace(tmp, a.out)
    print("real_stack: %s: label %d, %d slices of %dx%d, 1:%d" % (a.out, a.label, a.slices, a.size, a.size, a.ratio))


if __name__ == "__main__":
    main()
