#!/usr/bin/python3
"""Checks experiments/orex_eval.py on cases with known answers (run by hand:
/usr/bin/python3 experiments/test_orex_eval.py; prints the measured errors).

- Concentric spheres r = 1 and R = 1.1: every point of either sphere is R - r
  from the other, so Chamfer = Hausdorff = 0.1 / diagonal(reference) exactly
  for the true spheres; the meshes are inscribed, off the true sphere by at
  most R (1 - cos(h)) for angular edge h (TESSELLATION bounds it below).
- A mesh against itself: 0.
- Components and genus: two disjoint spheres (2, 0), a torus (1, 1).
- Section check: a sphere cut by the plane z = 0.3 against the drawn circle
  of radius sqrt(1 - 0.09): within the tessellation bound.
- CSL round trip: write_csl then read_csl gives the same planes.
"""
import os
import sys
import tempfile

import numpy as np
import vtk

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import orex_eval as E  # noqa: E402
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402

RES = 400  # theta/phi resolution of the sphere meshes
# Inscribed-mesh error bound: chord sagitta R (1 - cos(pi / RES)) ~ 3.4e-5 for R = 1.1,
# plus the flat-triangle interior (same order); 1e-4 covers both.
TESSELLATION = 1e-4
# Monte Carlo: the one-sided mean of a constant distance has no sampling error; the
# samples only matter through the tessellation, so the same bound applies to the mean.


def sphere(r, center=(0, 0, 0), res=RES):
    s = vtk.vtkSphereSource()
    s.SetRadius(r)
    s.SetCenter(*center)
    s.SetThetaResolution(res)
    s.SetPhiResolution(res)
    s.Update()
    p = s.GetOutput()
    V = vtk_to_numpy(p.GetPoints().GetData()).astype(float)
    F = vtk_to_numpy(p.GetPolys().GetData()).reshape(-1, 4)[:, 1:].astype(np.int64)
    return V, F


def torus():
    t = vtk.vtkParametricTorus()
    src = vtk.vtkParametricFunctionSource()
    src.SetParametricFunction(t)
    src.SetUResolution(80)
    src.SetVResolution(40)
    clean = vtk.vtkCleanPolyData()
    clean.SetInputConnection(src.GetOutputPort())
    clean.SetTolerance(1e-9)
    tri = vtk.vtkTriangleFilter()
    tri.SetInputConnection(clean.GetOutputPort())
    tri.Update()
    p = tri.GetOutput()
    V = vtk_to_numpy(p.GetPoints().GetData()).astype(float)
    F = vtk_to_numpy(p.GetPolys().GetData()).reshape(-1, 4)[:, 1:].astype(np.int64)
    return V, F


def check(name, got, want, tol):
    ok = abs(got - want) <= tol
    print("%-40s got %.8f want %.8f tol %.1e  %s" % (name, got, want, tol, "ok" if ok else "FAIL"))
    return ok


def main():
    ok = True
    Vi, Fi = sphere(1.0)
    Vo, Fo = sphere(1.1)
    diag = E.bbox_diagonal(Vo)
    for n in (20_000, 200_000):
        d1, d2 = E.surface_distances(Vi, Fi, Vo, Fo, n)
        ok &= check("spheres one-sided mean in->out n=%d" % n, d1.mean(), 0.1, TESSELLATION)
        ok &= check("spheres one-sided mean out->in n=%d" % n, d2.mean(), 0.1, TESSELLATION)
        ok &= check("spheres max n=%d" % n, max(d1.max(), d2.max()), 0.1, TESSELLATION)
    ch, hd = E.chamfer_hausdorff(Vi, Fi, Vo, Fo)
    ok &= check("spheres Chamfer share of diagonal", ch, 0.1 / diag, TESSELLATION / diag)
    ok &= check("spheres Hausdorff share of diagonal", hd, 0.1 / diag, TESSELLATION / diag)
    ch, hd = E.chamfer_hausdorff(Vi, Fi, Vi, Fi)
    ok &= check("self Chamfer", ch, 0.0, 1e-12)
    ok &= check("self Hausdorff", hd, 0.0, 1e-12)

    Va, Fa = sphere(1.0, res=40)
    Vb, Fb = sphere(1.0, (3, 0, 0), res=40)
    t = E.topology(np.vstack([Va, Vb]), np.vstack([Fa, Fb + len(Va)]))
    ok &= check("two spheres components", t["components"], 2, 0)
    ok &= check("two spheres genus", t["genus"], 0, 0)
    t = E.topology(*torus())
    ok &= check("torus components", t["components"], 1, 0)
    ok &= check("torus genus", t["genus"], 1, 0)
    ok &= check("torus boundary edges", t["boundary_edges"], 0, 0)

    z = 0.3
    rc = np.sqrt(1 - z * z)
    th = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    circle = np.c_[rc * np.cos(th), rc * np.sin(th), np.full_like(th, z)]
    plane = {"abcd": np.array([0, 0, 1.0, -z]), "vertices": circle,
             "components": [(1, -1, np.arange(len(th)))]}
    Vs, Fs = sphere(1.0)
    sec = E.section_check(Vs, Fs, [plane], 1.0)
    ok &= check("sphere section vs circle (abs)", sec[0], 0.0, TESSELLATION)

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "a.csl")
        hole = {"abcd": np.array([0, 0, 1.0, -z]), "vertices": np.vstack([circle, 0.5 * circle[::-1]]),
                "components": [(1, -1, np.arange(len(th))), (2, 0, len(th) + np.arange(len(th)))]}
        E.write_csl([plane, hole], path)
        back = E.read_csl(path)
        same = all(np.allclose(a["vertices"], b["vertices"], atol=1e-9) and np.allclose(a["abcd"], b["abcd"])
                   and [(c[0], c[1], list(c[2])) for c in a["components"]]
                   == [(c[0], c[1], list(c[2])) for c in b["components"]] for a, b in zip([plane, hole], back))
        ok &= check("CSL round trip", float(same), 1.0, 0)
        with open(path, "w") as f:
            f.write("CSLC\n1 2\n1 3 1 0 0 1 0\n0 0 0\n1 0 0\n0 1 0\n4 1 0 1 2\n")
        try:
            E.read_csl(path)
            ok &= check("CSL lying count rejected", 0.0, 1.0, 0)
        except ValueError as e:
            ok &= check("CSL lying count rejected (%s)" % str(e).split(": ", 1)[1][:30], 1.0, 1.0, 0)
    print("ALL OK" if ok else "FAILURES")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
