#!/usr/bin/python3
"""ctest real_anatomy_metrics: the benchmark's metrics (anatomy_metrics.py) on
analytic spheres whose answers are known. Exit status 1 on any failure."""
import math
import os
import sys

import numpy as np
import vtk
from vtk.util import numpy_support as ns

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import anatomy_metrics as am  # noqa: E402

R, C, N, NZ, DZ = 14.0, 24.0, 48, 33, 1.5  # sphere radius / centre (mm), grid 48 x 48 x 33 at dz 1.5 mm
# The truth's Marching Cubes triangles are chords of its level set: edges of
# up to 1.5 mm sag by e^2 / 8R = 0.02 mm on R = 14 mm (measured bias 0.021);
# a 200 x 200 sphere's facets lie within R (1 - cos(pi / 200)) = 0.002 mm of it.
DIST_TOL = 0.04  # mm
# A 200 x 200 sphere's facets are 0.28 degrees from radial on average, the
# gradient normals 0.16 (measured); a lookup off by one truth triangle gives ~1.
ANGLE_TOL = 0.6  # degrees
# Per-slice Dice at voxel centres of 31 slices against the exact 3D value.
DICE_TOL = 0.01


def sphere_mesh(radius, centre, res=200):
    s = vtk.vtkSphereSource()
    s.SetRadius(radius)
    s.SetCenter(*centre)
    s.SetThetaResolution(res)
    s.SetPhiResolution(res)
    s.Update()
    return s.GetOutput()


def truth_sphere():
    """Field sigmoid((R - r) / W): its 0.5 level set is exactly the sphere of
    radius R; W = 3 mm keeps it smooth on the grid (central-difference normals
    and Marching Cubes then within 0.2 degrees / 0.01 mm of the sphere)."""
    z, y, x = np.meshgrid(np.arange(NZ) * DZ, np.arange(N), np.arange(N), indexing="ij")
    r = np.sqrt((x - C) ** 2 + (y - C) ** 2 + (z - C) ** 2)
    return am.Truth((1.0 / (1.0 + np.exp(-(R - r) / 3.0))).astype(np.float32), DZ)


def terraced_sphere(planes, res=200):
    """Surface of revolution whose radius is linear in z between the sphere's
    cross-sections at `planes`: creases (normal errors) at the planes, the
    secant slope matching the sphere's about midway."""
    zs = np.linspace(planes[0], planes[-1], 300)
    rz = np.interp(zs, planes, np.sqrt(np.maximum(R * R - (planes - C) ** 2, 0.0)))
    th = np.linspace(0, 2 * np.pi, res, endpoint=False)
    P = np.stack([C + rz[:, None] * np.cos(th)[None, :], C + rz[:, None] * np.sin(th)[None, :],
                  np.repeat(zs[:, None], res, axis=1)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(len(zs) - 1), np.arange(res), indexing="ij")
    a, b = (i * res + j).ravel(), (i * res + (j + 1) % res).ravel()
    quads = np.concatenate([np.stack([a, b, b + res], 1), np.stack([a, b + res, a + res], 1)])
    poly = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    pts.SetData(ns.numpy_to_vtk(P, deep=1))
    poly.SetPoints(pts)
    cells = vtk.vtkCellArray()
    q = np.asarray(quads, np.int64)
    cells.SetData(ns.numpy_to_vtkIdTypeArray(np.arange(0, 3 * len(q) + 1, 3, dtype=np.int64), deep=1),
                  ns.numpy_to_vtkIdTypeArray(q.ravel(), deep=1))
    poly.SetPolys(cells)
    return poly


def main():
    fails = []

    def check(name, value, expect, tol):
        ok = abs(value - expect) <= tol
        print("%-40s %9.4f  expect %.4f +- %.4f  %s" % (name, value, expect, tol, "ok" if ok else "FAIL"))
        if not ok:
            fails.append(name)

    truth = truth_sphere()
    zlo, zhi = C - R, C + R
    planes = np.arange(0, NZ, 4) * DZ
    leftout = [k for k in range(1, NZ - 1) if k % 4]
    ev = lambda poly: am.evaluate(poly, truth, zlo, zhi, planes, 4 * DZ, leftout)  # noqa: E731

    same = ev(sphere_mesh(R, (C, C, C)))
    check("same sphere: mean distance", same["mean"], 0.0, DIST_TOL)
    check("same sphere: hausdorff", same["hausdorff"], 0.0, 2 * DIST_TOL)
    check("same sphere: normal angle", same["normal_deg"], 0.0, ANGLE_TOL)
    check("same sphere: dice", same["dice"], 1.0, DICE_TOL)

    big = ev(sphere_mesh(R + 0.5, (C, C, C)))
    check("radius + 0.5: mean", big["mean"], 0.5, DIST_TOL)
    check("radius + 0.5: p95", big["p95"], 0.5, DIST_TOL)
    check("radius + 0.5: hausdorff", big["hausdorff"], 0.5, DIST_TOL)

    s = 1.0  # shift along x: a point at angle t from x is |cos t| s away (to first order), mean s / 2
    sh = ev(sphere_mesh(R, (C + s, C, C)))
    check("shift 1 mm: mean", sh["mean"], 0.5 * s, 2 * DIST_TOL)
    check("shift 1 mm: hausdorff", sh["hausdorff"], s, DIST_TOL)
    # Two balls of radius R, centres d apart: intersection pi (4R + d)(2R - d)^2 / 12.
    inter = math.pi * (4 * R + s) * (2 * R - s) ** 2 / 12.0
    check("shift 1 mm: dice", sh["dice"], inter / (4.0 / 3.0 * math.pi * R ** 3), DICE_TOL)
    # The shift tilts normals by asin(s sin t / R): 1.5-3 degrees; not zero.
    if not sh["normal_deg"] > 1.0:
        fails.append("shift: normal angle should exceed 1 degree")

    ter = ev(terraced_sphere(planes[(planes >= zlo) & (planes <= zhi)]))
    ratio = ter["terrace"]
    print("%-40s %9.4f  expect > 2" % ("terraced sphere: terrace ratio", ratio))
    if not ratio > 2.0:
        fails.append("terrace ratio of creases at the input planes")
    print("%-40s %9.4f  expect within 0.5 of 1" % ("same sphere: terrace ratio", same["terrace"]))
    if not abs(same["terrace"] - 1.0) < 0.5:
        fails.append("terrace ratio of a smooth sphere")

    if fails:
        print("FAILED: " + "; ".join(fails))
        return 1
    print("all metric checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
