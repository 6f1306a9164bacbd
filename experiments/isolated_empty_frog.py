#!/usr/bin/python3
"""Question: where an organ of a label stack ends, its empty slices close it
(a closing slice next to the last drawn one, isolated ones beyond); how close
do the bundled frog example's meshes come to the dense truth under each
interp.isolated_empty rule (docs/decisions.md, isolated empty slices)? The
leaderboard (real_anatomy.py) cannot tell: its inputs end at the drawn
slices, so no empty slice is isolated.

data/frog is every 4th slice (from 0) of the Whole Frog map (1.5 mm apart;
6 mm in the example). Each run folder holds the example's meshes
(m_label<L>.ply, 1 mm pixels, slice i at z = 6 i). Each label is scored by
anatomy_metrics.evaluate against the staircase truth (real_anatomy's: the
dense mask smoothed by 0.7 mm) over the whole z range, caps included; Dice
on the slices between the inputs.

usage: isolated_empty_frog.py RUN_DIR [RUN_DIR ...]"""
import glob
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import anatomy_metrics as am  # noqa: E402
import anatomy_peers as peers  # noqa: E402
import isoloft_common as ic  # noqa: E402
import real_anatomy as ra  # noqa: E402

EVERY = 4  # data/frog keeps slices 0, 4, 8, ... of the dense map
SIGMA = ra.TRUTH_SIGMA_MM["staircase"]


def box(mask, pad_xy, pad_z):
    """(lo, hi) (z, y, x) of the mask's bounding box plus margins, within the volume."""
    idx = [np.nonzero(mask.any(axis=a))[0] for a in ((1, 2), (0, 2), (0, 1))]
    pads = (pad_z, pad_xy, pad_xy)
    return ([max(i[0] - p, 0) for i, p in zip(idx, pads)],
            [min(i[-1] + p + 1, n) for i, p, n in zip(idx, pads, mask.shape)])


def shifted(poly, dx, dy, dz):
    import vtk
    t = vtk.vtkTransform()
    t.Translate(dx, dy, dz)
    f = vtk.vtkTransformPolyDataFilter()
    f.SetTransform(t)
    f.SetInputData(poly)
    f.Update()
    return f.GetOutput()


def main():
    runs = sys.argv[1:]
    vol, sp = ic.read_frog(ra.FROG)
    dz = sp[2]
    labels = sorted(int(re.search(r"label(\d+)", p).group(1)) for p in glob.glob(os.path.join(runs[0], "m_label*.ply")))
    print("%-6s %-28s %8s %8s %8s %8s" % ("label", "run", "mean mm", "p95", "normal", "dice"))
    for label in labels:
        whole = vol == label
        pad_z = int(np.ceil(3 * SIGMA / dz)) + 1
        lo, hi = box(whole, ra.CROP_PAD, pad_z)
        # Zero-padded so the smoothed truth closes inside the crop.
        mask = np.zeros([h - l + 2 * p for l, h, p in zip(lo, hi, (pad_z, ra.CROP_PAD, ra.CROP_PAD))], bool)
        mask[pad_z:pad_z + hi[0] - lo[0], ra.CROP_PAD:ra.CROP_PAD + hi[1] - lo[1], ra.CROP_PAD:ra.CROP_PAD + hi[2] - lo[2]] = \
            whole[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
        z0, y0, x0 = lo[0] - pad_z, lo[1] - ra.CROP_PAD, lo[2] - ra.CROP_PAD  # volume index of crop index 0
        tr = am.Truth.smoothed(mask, dz, SIGMA)
        nz = mask.shape[0]
        inputs = [k for k in range(nz) if (k + z0) % EVERY == 0 and 0 <= k + z0 < vol.shape[0]]
        leftout = [k for k in range(inputs[0] + 1, inputs[-1]) if k not in set(inputs)]
        geo = dict(z_lo=0.0, z_hi=(nz - 1) * dz, planes=[k * dz for k in inputs], spacing=EVERY * dz, leftout=leftout)
        for run in runs:
            poly = shifted(peers.read_mesh(os.path.join(run, "m_label%d.ply" % label)), -x0, -y0, -z0 * dz)
            r = am.evaluate(poly, tr, **geo)
            print("%-6d %-28s %8.4f %8.4f %8.3f %8.4f" % (label, os.path.basename(run.rstrip("/")), r["mean"], r["p95"],
                                                       r["normal_deg"], r["dice"]), flush=True)


if __name__ == "__main__":
    main()
