"""Peer systems for the real-anatomy benchmark (experiments/real_anatomy.py).

Each peer is `run_<name>(masks, kept) -> vtkPolyData` with
  masks  bool (nz, ny, nx); only the slices in `kept` are read
  kept   sorted slice indices given as input (evenly spaced)
and returns a mesh in voxel coordinates (x = column, y = row, z = slice
index, voxel centres at integers); the caller scales z to millimetres.
Debian's python3-vtk9 / python3-scipy; `mci` needs node and `npm ci` in
experiments/peers_node (scripts/real_anatomy.sh does it).

  vtk       VTK's vtkVoxelContoursToSurfaceFilter on polygons traced from each mask
  mci       ITK MorphologicalContourInterpolator (3D Slicer's "Fill between slices", ITK-Wasm
            in node) + Slicer's labelmap -> closed surface rule (discrete flying edges, windowed sinc)
  slicerrt  SlicerRT-style rasterization rule: per-slice signed pixel distances, linear in z,
            Marching Cubes at 0, Slicer's windowed-sinc smoothing. SlicerRT's own planar-contour ->
            closed-surface rule triangulates between contours instead (not reproduced here)
  nearest   every slice copies the nearest input slice (ties: the lower), Marching Cubes at 0.5
"""
import json
import os
import subprocess
import tempfile
import time

import numpy as np
from scipy import ndimage
import vtk
from vtk.util import numpy_support as ns

NODE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "peers_node")

# 3D Slicer's vtkBinaryLabelmapToClosedSurfaceConversionRule defaults:
# smoothing factor 0.5 -> windowed sinc, 20 iterations, pass band 10^(-4 * 0.5).
SLICER_SMOOTHING_FACTOR = 0.5
SLICER_SMOOTHING_ITERATIONS = 20
# An empty input slice in the distance stack: far outside, so the surface
# closes at the last non-empty slice (SlicerRT rasterizes nothing there).
EMPTY_SDF = -1.0e6


def image(arr, origin):
    """vtkImageData from a (nz, ny, nx) array, voxel (z, y, x) at origin + (x, y, z)."""
    nz, ny, nx = arr.shape
    img = vtk.vtkImageData()
    img.SetDimensions(nx, ny, nz)
    img.SetOrigin(*[float(o) for o in origin])
    img.SetSpacing(1.0, 1.0, 1.0)
    img.GetPointData().SetScalars(ns.numpy_to_vtk(np.ascontiguousarray(arr).ravel(), deep=1))
    return img


def flying_edges(arr, origin, level, discrete=False):
    fe = vtk.vtkDiscreteFlyingEdges3D() if discrete else vtk.vtkFlyingEdges3D()
    fe.SetInputData(image(arr, origin))
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    if not discrete:
        fe.ComputeScalarsOff()
    fe.SetValue(0, level)
    fe.Update()
    return fe.GetOutput()


def slicer_smooth(poly):
    """Slicer's smoothing (done there in IJK, as here) and its normals step."""
    s = vtk.vtkWindowedSincPolyDataFilter()
    s.SetInputData(poly)
    s.SetNumberOfIterations(SLICER_SMOOTHING_ITERATIONS)
    s.SetPassBand(10.0 ** (-4.0 * SLICER_SMOOTHING_FACTOR))
    s.BoundarySmoothingOff()
    s.FeatureEdgeSmoothingOff()
    s.NonManifoldSmoothingOn()
    s.NormalizeCoordinatesOn()
    s.Update()
    n = vtk.vtkPolyDataNormals()
    n.SetInputData(s.GetOutput())
    n.ConsistencyOn()
    n.SplittingOff()
    n.Update()
    return n.GetOutput()


def _nonempty(masks, kept):
    ne = [z for z in kept if masks[z].any()]
    if not ne:
        raise ValueError("no input slice holds the structure")
    return ne


def _labels_surface(labels, discrete=True, smooth=True):
    """Closed surface of a bool volume (cropped, padded by one empty voxel)."""
    zs, ys, xs = (np.nonzero(labels.any(axis=a))[0] for a in ((1, 2), (0, 2), (0, 1)))
    crop = np.pad(labels[zs[0]:zs[-1] + 1, ys[0]:ys[-1] + 1, xs[0]:xs[-1] + 1], 1).astype(np.uint8)
    poly = flying_edges(crop, (xs[0] - 1, ys[0] - 1, zs[0] - 1), 1 if discrete else 0.5, discrete)
    return slicer_smooth(poly) if smooth else poly


# ---------------------------------------------------------------- VTK

def iso_lines(arr, origin, level):
    """Level-`level` lines of a 2D array (vtkFlyingEdges2D, joined by
    vtkStripper): (points (n, 2), [point ids per line])."""
    img = vtk.vtkImageData()
    img.SetDimensions(arr.shape[1], arr.shape[0], 1)
    img.SetOrigin(origin[0], origin[1], 0.0)
    img.GetPointData().SetScalars(ns.numpy_to_vtk(np.ascontiguousarray(arr).ravel(), deep=1))
    fe = vtk.vtkFlyingEdges2D()
    fe.SetInputData(img)
    fe.SetValue(0, level)
    st = vtk.vtkStripper()
    st.SetInputConnection(fe.GetOutputPort())
    st.JoinContiguousSegmentsOn()
    st.SetMaximumLength(1 << 30)
    st.Update()
    pd = st.GetOutput()
    if pd.GetNumberOfLines() == 0:
        return np.zeros((0, 2)), []
    P = ns.vtk_to_numpy(pd.GetPoints().GetData())[:, :2].astype(np.float64)
    off = ns.vtk_to_numpy(pd.GetLines().GetOffsetsArray())
    conn = ns.vtk_to_numpy(pd.GetLines().GetConnectivityArray())
    return P, [conn[off[i]:off[i + 1]] for i in range(len(off) - 1)]


def _slice_polygons(mask):
    """Closed polygons of one mask (level 0.5 of the zero-padded mask), in
    pixel coordinates: vertices at pixel-edge midpoints."""
    P, lines = iso_lines(np.pad(mask, 1).astype(np.uint8), (-1.0, -1.0), 0.5)
    polys = []
    for ids in lines:
        if len(ids) < 4 or ids[0] != ids[-1]:
            raise RuntimeError("open contour from vtkStripper (%d points)" % len(ids))
        polys.append(P[ids[:-1]])
    return polys


trace_polygons = _slice_polygons  # the polyline input of isoloft is traced the same way


def polygons_polydata(slices):
    """One vtkPolyData of polys (vtkVoxelContoursToSurfaceFilter reads polys
    only) from per-slice lists of (n, 2) polygons; slice r at z = r (the
    filter steps z by exactly 1)."""
    pts, offsets, n = [], [0], 0
    for r, polys in enumerate(slices):
        for q in polys:
            pts.append(np.column_stack([q, np.full(len(q), float(r))]))
            n += len(q)
            offsets.append(n)
    pd = vtk.vtkPolyData()
    points = vtk.vtkPoints()
    points.SetData(ns.numpy_to_vtk(np.concatenate(pts), deep=1))
    cells = vtk.vtkCellArray()
    cells.SetData(ns.numpy_to_vtkIdTypeArray(np.array(offsets, dtype=np.int64), deep=1),
                  ns.numpy_to_vtkIdTypeArray(np.arange(n, dtype=np.int64), deep=1))
    pd.SetPoints(points)
    pd.SetPolys(cells)
    return pd


def run_vtk(masks, kept):
    """vtkVoxelContoursToSurfaceFilter (VTK 9.1). Its quirks:
    - slices advance z by exactly 1: slice r goes to z = r, SetSpacing scales;
    - scan lines at (bounds min - 0.5) + n with strict intersection tests, so a
      vertex on a scan line flips parity: mask contours have half-integer
      vertices, so x, y are doubled and SetSpacing(0.5, 0.5, step) undoes it;
    - the output grid's offset is corrected by voxel_contours_surface.
    Each end closes as a flat lid."""
    ne = _nonempty(masks, kept)
    ks = [z for z in kept if ne[0] <= z <= ne[-1]]
    steps = set(np.diff(ks).tolist())
    if len(steps) > 1:
        raise ValueError("vtkVoxelContoursToSurfaceFilter needs evenly spaced slices, got %s" % sorted(steps))
    step = steps.pop() if steps else 1
    slices = []
    for z in ks:
        polys = [2.0 * q for q in _slice_polygons(masks[z])]
        assert all(np.all(np.abs(q - np.rint(q)) < 1e-4) for q in polys)
        slices.append([np.rint(q) for q in polys])
    contours = polygons_polydata(slices)
    out = voxel_contours_surface(contours, (0.5, 0.5, float(step)))
    P = ns.vtk_to_numpy(out.GetPoints().GetData())
    P[:, 2] += ks[0]
    out.GetPoints().Modified()
    return out


def voxel_contours_surface(contours, spacing):
    """vtkVoxelContoursToSurfaceFilter with its output moved to the input's
    units: its grid origin (bounds min - 0.5 in x, y; zmin - 1 in z) is in
    input units but the grid is spaced by `spacing`, so every point is shifted
    by gridOrigin * (spacing - 1). Chunks of MemoryLimitInBytes are contoured
    apart: limit 1 GiB, and vtkCleanPolyData merges any seam points."""
    f = vtk.vtkVoxelContoursToSurfaceFilter()
    f.SetInputData(contours)
    f.SetSpacing(*spacing)
    f.SetMemoryLimitInBytes(1 << 30)
    f.Update()
    out = f.GetOutput()
    b = contours.GetBounds()
    grid_origin = (b[0] - 0.5, b[2] - 0.5, b[4] - 1.0)
    P = ns.vtk_to_numpy(out.GetPoints().GetData())
    for ax in range(3):
        P[:, ax] += grid_origin[ax] * (spacing[ax] - 1.0)
    out.GetPoints().Modified()
    c = vtk.vtkCleanPolyData()
    c.SetInputData(out)
    c.Update()
    return c.GetOutput()


# ---------------------------------------------------------------- ITK MCI

def mci_labels(masks, kept):
    """ITK MorphologicalContourInterpolator with Slicer's settings (Axis -1,
    heuristic alignment, repeated dilations instead of the distance transform,
    cross structuring element, extrapolation, labelled slices auto-detected).
    The wasm wrapper inverts the ball flag, so --ball gives the cross element."""
    ne = _nonempty(masks, kept)
    nz = masks.shape[0]
    z0, z1 = max(ne[0] - 1, 0), min(ne[-1] + 2, nz)
    sub = np.zeros((z1 - z0,) + masks.shape[1:], np.uint8)
    for z in kept:
        if z0 <= z < z1:
            sub[z - z0] = masks[z]
    with tempfile.TemporaryDirectory() as tmp:
        fin, fout = os.path.join(tmp, "in.raw"), os.path.join(tmp, "out.raw")
        sub.tofile(fin)
        cmd = ["node", os.path.join(NODE_DIR, "mci.mjs"), fin, fout, str(sub.shape[2]), str(sub.shape[1]),
               str(sub.shape[0]), "--axis", "-1", "--label", "1", "--ball", "--no-dt"]
        res = subprocess.run(cmd, cwd=NODE_DIR, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError("mci.mjs failed (%d): %s" % (res.returncode, res.stderr[-2000:]))
        json.loads(res.stdout.strip().splitlines()[-1])
        out = np.fromfile(fout, np.uint8).reshape(sub.shape)
    full = np.zeros(masks.shape, bool)
    full[z0:z1] = out > 0
    return full


def run_mci(masks, kept):
    return _labels_surface(mci_labels(masks, kept))


def mci_available():
    return os.path.isfile(os.path.join(NODE_DIR, "node_modules", "@itk-wasm",
                                       "morphological-contour-interpolation", "package.json"))


# ---------------------------------------------------------------- SlicerRT-style rasterization rule

def slice_sdf(mask):
    """Signed Euclidean pixel distance, > 0 inside, 0 on the half-pixel boundary."""
    din = ndimage.distance_transform_edt(mask)
    dout = ndimage.distance_transform_edt(~mask)
    return np.where(mask, din - 0.5, 0.5 - dout).astype(np.float32)


def run_slicerrt(masks, kept):
    ne = _nonempty(masks, kept)
    ks = [z for z in kept if ne[0] <= z <= ne[-1]]
    z0 = ne[0] - 1  # one empty slice each end closes the surface at the end slices
    vol = np.full((ne[-1] + 2 - z0,) + masks.shape[1:], EMPTY_SDF, np.float32)
    sd = {z: slice_sdf(masks[z]) if masks[z].any() else np.full(masks.shape[1:], EMPTY_SDF, np.float32) for z in ks}
    for z in ks:
        vol[z - z0] = sd[z]
    for a, b in zip(ks[:-1], ks[1:]):
        for z in range(a + 1, b):
            t = (z - a) / (b - a)
            vol[z - z0] = (1 - t) * sd[a] + t * sd[b]
    return slicer_smooth(flying_edges(vol, (0, 0, z0), 0.0))


# ---------------------------------------------------------------- nearest-slice copy

def run_nearest(masks, kept):
    ne = _nonempty(masks, kept)
    kept = np.asarray([z for z in kept if ne[0] <= z <= ne[-1]])
    z = np.arange(ne[0], ne[-1] + 1)
    src = kept[np.argmin(np.abs(z[:, None] - kept[None, :]), axis=1)]  # argmin: the lower on ties
    labels = np.zeros(masks.shape, bool)
    labels[z] = masks[src]
    return _labels_surface(labels, discrete=False, smooth=False)


PEERS = {"vtk": run_vtk, "mci": run_mci, "slicerrt": run_slicerrt, "nearest": run_nearest}


def timed(peer, masks, kept):
    t = time.perf_counter()
    poly = PEERS[peer](masks, kept)
    return poly, time.perf_counter() - t


def write_ply(poly, path):
    w = vtk.vtkPLYWriter()
    w.SetFileTypeToBinary()
    w.SetFileName(path)
    w.SetInputData(poly)
    w.Write()


def read_mesh(path):
    ext = os.path.splitext(path)[1].lower()
    r = {".obj": vtk.vtkOBJReader, ".stl": vtk.vtkSTLReader}.get(ext, vtk.vtkPLYReader)()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()
