#!/usr/bin/env python3
"""ITK MorphologicalContourInterpolator (3D Slicer's Fill between slices) on
the tilted-tube kit's masks, for experiments/tilted_tubes.cpp's peer column.

Reads DIR/<case>/slice_NNN.png and DIR/<case>/z.txt (tilted_tubes
--write-masks: whole-pixel slice z), runs the peer as the real-anatomy
benchmark does (anatomy_peers.run_mci: Slicer's settings, surface by
discrete flying edges and Slicer's smoothing) and writes DIR/<case>/mci.ply
in the kit's pixel frame.

usage: tilted_tubes_mci.py DIR
"""
import os
import sys

import numpy as np
import vtk
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import anatomy_peers as peers  # noqa: E402


def main():
    root = sys.argv[1]
    if not peers.mci_available():
        sys.exit("tilted_tubes_mci: the ITK-Wasm peer is not installed (npm ci in %s)" % peers.NODE_DIR)
    for case in sorted(os.listdir(root)):
        d = os.path.join(root, case)
        if not os.path.isfile(os.path.join(d, "z.txt")):
            continue
        z = [float(v) for v in open(os.path.join(d, "z.txt")).read().strip().split(",")]
        zi = [int(round(v)) for v in z]
        if not np.allclose(zi, z):
            print("tilted_tubes_mci: %s: slice z not whole pixels, skipped" % case)
            continue
        files = sorted(f for f in os.listdir(d) if f.startswith("slice_") and f.endswith(".png"))
        masks = [np.asarray(Image.open(os.path.join(d, f))) > 0 for f in files]
        # The dense stack the peer reads: the masks at their z, empty between.
        vol = np.zeros((zi[-1] + 2,) + masks[0].shape, bool)
        for k, m in zip(zi, masks):
            vol[k] = m
        poly = peers.run_mci(vol, zi)
        w = vtk.vtkPLYWriter()
        w.SetFileName(os.path.join(d, "mci.ply"))
        w.SetInputData(poly)
        w.SetFileTypeToBinary()
        w.Write()
        print("tilted_tubes_mci: %s: %d triangles" % (case, poly.GetNumberOfPolys()))


if __name__ == "__main__":
    main()
