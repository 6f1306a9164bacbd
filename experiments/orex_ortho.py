#!/usr/bin/python3
"""Orthogonal axis-aligned section sets cut from OReX's reference meshes, and
ITK's MorphologicalContourInterpolator (axis = -1) on them (issue 35's peer).

OReX's CSL planes are oblique; MorphologicalContourInterpolator only takes
label volumes annotated on axis-aligned slices. So the bench adds, per shape,
a second input: PER_AXIS planes across the reference's bounding box along each
of x, y and z, on the voxel lattice of spacing H through the origin, cut from
the reference mesh as OReX's Slicer.py cuts its planes (written as a CSL file:
every method reads the same file). The peer rasterises that file's loops on
the lattice (a voxel centre on an annotated slice is inside by the even-odd
rule over the plane's loops), runs the filter with 3D Slicer's "Fill between
slices" settings and axis = -1 (all three orientations at once, the annotated
slices auto-detected), and meshes the labels as Slicer does.

Debian 12's ITK 5.2 (libinsighttoolkit5-dev) does not ship the filter (a
remote module; the package's header list has no itkMorphologicalContour*), so
the filter runs from the ITK-Wasm build in experiments/peers_node (npm ci there).

usage: orex_ortho.py make REFERENCE.stl OUT.csl [--per-axis N]
       orex_ortho.py mci IN.csl OUT.{stl,ply,vtp}
Prints one JSON line (mci: seconds, voxels).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import anatomy_peers as peers  # noqa: E402
import orex_eval as E  # noqa: E402
from rbf_baseline import even_odd_inside  # noqa: E402

# Planes per axis: 5 x 3 = 15 planes, the count of OReX's eight_15 and balloondog.
PER_AXIS = 5
# Voxel size of the lattice the planes sit on, in the CSL frame (OReX scales
# shapes into [-1/1.1, 1/1.1]): 128 voxels across [-1, 1], so the peer's
# volume is at most 117 voxels along a side.
H = 1.0 / 64
# Offset of a plane coordinate from the lattice allowed when reading a set
# back (the CSL stores 10 decimals).
LATTICE_TOL = 1e-7


def section_loops(poly, axis, c):
    """Closed loops (list of (k,3)) of the mesh on the plane x[axis] = c."""
    n = np.zeros(3)
    n[axis] = 1
    plane = vtk.vtkPlane()
    plane.SetOrigin(*(n * c))
    plane.SetNormal(*n)
    cut = vtk.vtkCutter()
    cut.SetCutFunction(plane)
    cut.SetInputData(poly)
    st = vtk.vtkStripper()
    st.JoinContiguousSegmentsOn()
    st.SetMaximumLength(1 << 30)
    clean = vtk.vtkCleanPolyData()  # merges the cutter's coincident points first
    clean.SetInputConnection(cut.GetOutputPort())
    st.SetInputConnection(clean.GetOutputPort())
    st.Update()
    pd = st.GetOutput()
    if pd.GetNumberOfLines() == 0:
        return []
    P = vtk_to_numpy(pd.GetPoints().GetData()).astype(np.float64)
    off = vtk_to_numpy(pd.GetLines().GetOffsetsArray())
    conn = vtk_to_numpy(pd.GetLines().GetConnectivityArray())
    loops = []
    for a, b in zip(off[:-1], off[1:]):
        ids = conn[a:b]
        if len(ids) >= 4 and ids[0] == ids[-1]:
            loops.append(P[ids[:-1]])
    return loops


def make_plane(axis, c, loops):
    """A CSL plane (read_csl's form): outer loops CCW about +axis, holes CW with
    their parent (the innermost loop holding them), label 1 / 2 as OReX writes."""
    u, v = [i for i in range(3) if i != axis]
    if axis == 1:
        u, v = v, u  # (z, x): right-handed about +y
    two = [np.c_[L[:, u], L[:, v]] for L in loops]
    contains = np.zeros((len(loops), len(loops)), bool)
    for i in range(len(loops)):
        for j in range(len(loops)):
            if i != j:
                contains[j, i] = even_odd_inside(two[i][:1], [two[j]])[0]
    depth = contains.sum(0)
    verts, comps, start = [], [], 0
    for i, L in enumerate(loops):
        x, y = two[i][:, 0], two[i][:, 1]
        ccw = (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() > 0
        hole = depth[i] % 2 == 1
        if ccw == hole:
            L = L[::-1]
        parent = -1
        if hole:
            holders = np.nonzero(contains[:, i])[0]
            parent = int(holders[np.argmax(depth[holders])])
        verts.append(L)
        comps.append((2 if hole else 1, parent, start + np.arange(len(L))))
        start += len(L)
    abcd = np.zeros(4)
    abcd[axis], abcd[3] = 1.0, -c
    return {"abcd": abcd, "vertices": np.vstack(verts), "components": comps}


def make(ref_path, out_path, per_axis=PER_AXIS):
    V, F = E.read_mesh(ref_path)
    poly = E.to_polydata(V, F)
    lo, hi = V.min(0), V.max(0)
    planes = []
    for axis in range(3):
        for k in range(per_axis):
            c = H * np.round((lo[axis] + (k + 0.5) / per_axis * (hi[axis] - lo[axis])) / H)
            loops = section_loops(poly, axis, c)
            if loops:
                planes.append(make_plane(axis, c, loops))
    E.write_csl(planes, out_path)
    return {"planes": len(planes)}


def rasterise(planes):
    """Label volume (z, y, x) uint8 on the lattice, its origin (x, y, z) and the
    annotated slice count; errors if a plane is oblique or off the lattice."""
    allv = np.vstack([p["vertices"] for p in planes])
    lo = H * (np.floor(allv.min(0) / H) - 2)
    hi = H * (np.ceil(allv.max(0) / H) + 2)
    dims = np.round((hi - lo) / H).astype(int) + 1  # (x, y, z)
    vol = np.zeros(dims[::-1], np.uint8)
    for i, p in enumerate(planes):
        n = p["abcd"][:3] / np.linalg.norm(p["abcd"][:3])
        axis = int(np.argmax(np.abs(n)))
        if abs(abs(n[axis]) - 1) > LATTICE_TOL:
            raise ValueError("plane %d is not axis-aligned (normal %s)" % (i + 1, n))
        c = -p["abcd"][3] / p["abcd"][axis]
        k = (c - lo[axis]) / H
        if abs(k - round(k)) > LATTICE_TOL / H:
            raise ValueError("plane %d (x%d = %.10f) is off the %.6f lattice" % (i + 1, axis, c, H))
        k = int(round(k))
        u, v = [j for j in range(3) if j != axis]
        gu, gv = lo[u] + H * np.arange(dims[u]), lo[v] + H * np.arange(dims[v])
        U, W = np.meshgrid(gu, gv, indexing="ij")
        loops2 = [np.c_[L[:, u], L[:, v]] for L in E.csl_loops(p)]
        inside = even_odd_inside(np.c_[U.ravel(), W.ravel()], loops2).reshape(len(gu), len(gv))
        sl = [slice(None)] * 3
        sl[2 - axis] = k  # vol is (z, y, x): the slice's axes are (v, u)
        vol[tuple(sl)] |= inside.T.astype(np.uint8)
    return vol, lo


def mci(csl_path, out_path):
    if not peers.mci_available():
        raise RuntimeError("the ITK-Wasm filter is not installed (npm ci in %s)" % peers.NODE_DIR)
    planes = E.read_csl(csl_path)
    t0 = time.perf_counter()
    vol, lo = rasterise(planes)
    nz, ny, nx = vol.shape
    with tempfile.TemporaryDirectory() as tmp:
        fin, fout = os.path.join(tmp, "in.raw"), os.path.join(tmp, "out.raw")
        vol.tofile(fin)
        # Slicer's settings (anatomy_peers.mci_labels): heuristic alignment, repeated
        # dilations, cross element (the wrapper inverts --ball), extrapolation.
        cmd = ["node", os.path.join(peers.NODE_DIR, "mci.mjs"), fin, fout, str(nx), str(ny), str(nz),
               "--axis", "-1", "--label", "1", "--ball", "--no-dt"]
        res = subprocess.run(cmd, cwd=peers.NODE_DIR, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError("mci.mjs failed (%d): %s" % (res.returncode, res.stderr[-2000:]))
        out = np.fromfile(fout, np.uint8).reshape(vol.shape) > 0
    poly = peers._labels_surface(out)
    V = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64) * H + lo
    F = vtk_to_numpy(poly.GetPolys().GetData()).reshape(-1, 4)[:, 1:].astype(np.int64)
    E.write_mesh(V, F, out_path)
    return {"voxels": [int(nx), int(ny), int(nz)], "seconds": time.perf_counter() - t0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("make")
    m.add_argument("reference")
    m.add_argument("out")
    m.add_argument("--per-axis", type=int, default=PER_AXIS)
    r = sub.add_parser("mci")
    r.add_argument("csl")
    r.add_argument("out")
    a = ap.parse_args()
    try:
        info = make(a.reference, a.out, a.per_axis) if a.cmd == "make" else mci(a.csl, a.out)
    except ValueError as e:
        sys.exit("orex_ortho: %s" % e)
    print(json.dumps(info))


if __name__ == "__main__":
    main()
