#!/usr/bin/python3
"""Benchmark (not a test): isoloft vs the VTK baseline users have today,
vtkVoxelContoursToSurfaceFilter + vtkQuadricDecimation, on the same synthetic
jawbone-sized contour stack (`isoloft synth branching-cylinders`, 500 x 500,
z spacing 8: 63 slices, 61 with contours).

Runs alternate (isoloft, vtk, isoloft, vtk, ...) --runs times each. isoloft is
timed by wall clock around the CLI (plus its --report stage times); VTK
in-process: contour extraction (PNG read + vtkFlyingEdges2D + vtkStripper),
surface (vtkVoxelContoursToSurfaceFilter + vtkCleanPolyData to merge its chunk
seams) and decimation. Afterwards both meshes are compared with the analytic
truth (`isoloft eval`). Writes a JSON (medians, all runs, triangle counts,
bounding boxes, accuracy, machine) and prints a table.

usage: vtk_side_by_side.py [--size 500] [--z-spacing 8] [--runs 5] [--threads N]
                           [--decimate-error 0.25] [--vtk-reduction match|R]
                           [--out result.json] [--isoloft build/isoloft]
Run with Debian's /usr/bin/python3 (python3-numpy, python3-vtk9), e.g. via
scripts/vtk_side_by_side.sh.
"""
import argparse
import json
import os
import platform
import re
import shutil
import sys
import time

try:
    import vtk
    from vtk.util import numpy_support as ns
except ImportError:
    print("vtk_side_by_side: python3-vtk9 not installed; skipped")
    sys.exit(0)
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402
from anatomy_peers import iso_lines, polygons_polydata, voxel_contours_surface  # noqa: E402

SHAPE = "branching-cylinders"


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", type=int, default=500, help="image width and height, px")
    p.add_argument("--z-spacing", type=float, default=8.0, help="slice spacing, px")
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--threads", type=int, default=os.cpu_count())
    p.add_argument("--decimate-error", type=float, default=0.25, help="isoloft --decimate-error, px")
    p.add_argument("--vtk-reduction", default="match",
                   help="vtkQuadricDecimation target reduction: 'match' (isoloft's decimated triangle count) or a fraction")
    p.add_argument("--out", default=os.path.join(ic.ROOT, "experiments/out/vtk_side_by_side/result.json"))
    p.add_argument("--isoloft", default=os.path.join(ic.ROOT, "build/isoloft"))
    return p.parse_args()


# ---------------------------------------------------------------- VTK side

def slice_files(stack):
    names = [f for f in os.listdir(stack) if f.endswith(".png")]
    return [os.path.join(stack, f) for f in sorted(names, key=lambda f: int(re.sub(r"\D", "", f) or 0))]


def read_white(path):
    """Contour pixels of one slice, as a bool array [row, col] (row = y, as isoloft)."""
    r = vtk.vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    img = r.GetOutput()
    w, h, _ = img.GetDimensions()
    a = ns.vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[::-1, :, 0]
    # [::-1]: vtkPNGReader puts the PNG's top row at the largest y (FileLowerLeft is ignored).
    return a > np.iinfo(a.dtype).max / 2


def slice_polygons(path):
    """Closed polygons through contour pixel centres (integer x, y, as
    vtkVoxelContoursToSurfaceFilter requires), one per contour curve."""
    return white_polygons(read_white(path))


def white_polygons(white):
    """slice_polygons() of a bool contour image [row, col]."""
    w = np.pad(white, 1)  # black border: every curve closes
    # Contour the background (black = 255): VTK's marching squares cuts off the
    # above-value corners of a saddle cell, so black stays 4-connected and the
    # 8-connected white curves stay closed, as in isoloft's even-odd fill.
    # Origin -1: x, y are the unpadded pixel coordinates.
    P, lines = iso_lines((~w).astype(np.uint8) * 255, (-1.0, -1.0), 127.5)
    if not lines:
        return []
    # Every vertex is the midpoint of a pixel edge with one white end: snap it
    # to the white (contour) pixel centre.
    S = P.copy()
    for ax in (0, 1):
        half = np.abs(P[:, ax] - np.floor(P[:, ax]) - 0.5) < 1e-6
        lo = np.floor(P[half, ax]).astype(int)
        other = np.rint(P[half, 1 - ax]).astype(int)
        rows, cols = (other + 1, lo + 1) if ax == 0 else (lo + 1, other + 1)
        S[half, ax] = np.where(w[rows, cols], lo, lo + 1)
    polys = []
    for ids in lines:
        if len(ids) > 1 and ids[0] == ids[-1]:
            ids = ids[:-1]
        # Each white curve has a black region each side, so two curves; snapping
        # shrinks the one enclosing it (kept) and grows the one inside (dropped).
        # Even-odd over the kept curves then gives nested contours as holes.
        if abs(shoelace(S[ids])) >= abs(shoelace(P[ids])):
            continue
        q = S[ids]
        q = q[np.any(q != np.roll(q, 1, axis=0), axis=1)]  # drop repeats from snapping
        if len(q) >= 3:
            polys.append(q)
    return polys


def shoelace(q):
    return 0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])


def contours_polydata(files):
    """All slices' polygons in one vtkPolyData, ordered by slice, z = slice index."""
    return polygons_polydata([slice_polygons(f) for f in files])


def vtk_surface(contours, z_spacing):
    return voxel_contours_surface(contours, (1.0, 1.0, z_spacing))


def vtk_decimate(mesh, reduction):
    d = vtk.vtkQuadricDecimation()
    d.SetInputData(mesh)
    d.SetTargetReduction(reduction)
    d.Update()
    return d.GetOutput()


def run_vtk(files, z_spacing, reduction_for):
    t0 = time.perf_counter()
    contours = contours_polydata(files)
    t1 = time.perf_counter()
    surf = vtk_surface(contours, z_spacing)
    t2 = time.perf_counter()
    reduction = reduction_for(surf.GetNumberOfPolys())
    dec = vtk_decimate(surf, reduction)
    t3 = time.perf_counter()
    return {"vtk_extract_s": t1 - t0, "vtk_surface_s": t2 - t1, "vtk_decimate_s": t3 - t2, "vtk_total_s": t3 - t0,
            "contour_polygons": contours.GetNumberOfPolys(), "triangles_surface": surf.GetNumberOfPolys(),
            "triangles": dec.GetNumberOfPolys(), "target_reduction": reduction,
            "bbox_px_undecimated": [list(surf.GetBounds()[0::2]), list(surf.GetBounds()[1::2])]}, dec


# ---------------------------------------------------------------- isoloft side

def run_isoloft(exe, stack, ply, report, a):
    cmd = [exe, "reconstruct", stack, "--z-spacing", "%g" % a.z_spacing, "-o", ply, "--decimate-error",
           str(a.decimate_error), "--threads", str(a.threads), "-q", "--report", report]
    t0 = time.perf_counter()
    ic.run(cmd)
    wall = time.perf_counter() - t0
    rep = ic.read_json(report)
    ob = rep["objects"][0]
    return {"wall_s": wall, "stages_s": rep["timings_s"], "triangles": ob["triangles"],
            "triangles_before_decimation": ob["triangles_before_decimation"], "closed": ob["closed"],
            "manifold": ob["manifold"], "peak_memory_mib": rep.get("peak_memory_mib")}


# ---------------------------------------------------------------- both

def bbox(points):
    return [[round(float(v), 3) for v in points.min(axis=0)], [round(float(v), 3) for v in points.max(axis=0)]]


def accuracy(exe, mesh, stack):
    """`isoloft eval` against the analytic truth (after timing): speed alone says little."""
    e = json.loads(ic.run([exe, "eval", "--mesh", mesh, "--truth", os.path.join(stack, "shape.json")]).stdout)
    return {"two_sided": e["two_sided"]["in_range"], "hausdorff": e["two_sided"]["hausdorff"],
            "mesh_to_truth": e["mesh_to_truth"]["in_range"]}


def machine():
    model = ""
    try:
        with open("/proc/cpuinfo") as f:
            model = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    return {"nproc": os.cpu_count(), "cpu_model": model, "platform": platform.platform(),
            "python": platform.python_version(), "vtk": vtk.vtkVersion.GetVTKVersion(),
            "vtk_smp_backend": vtk.vtkSMPTools.GetBackend(), "numpy": np.__version__}


def main():
    a = parse_args()
    exe = os.path.abspath(a.isoloft)
    if not os.access(exe, os.X_OK):
        sys.exit("vtk_side_by_side: isoloft binary not found at %s (build it: scripts/setup.sh)" % exe)
    vtk.vtkSMPTools.Initialize(a.threads)  # VTK's threaded filters get the same thread count
    work = os.path.dirname(os.path.abspath(a.out))
    stack, ply, report = (os.path.join(work, n) for n in ("stack", "isoloft.ply", "isoloft_report.json"))
    shutil.rmtree(stack, ignore_errors=True)  # no stale slices from a larger stack
    os.makedirs(work, exist_ok=True)
    ic.run([exe, "synth", SHAPE, "--size", a.size, "--z-spacing", "%g" % a.z_spacing, "--out", stack])
    files = slice_files(stack)

    iso_runs, vtk_runs, vtk_mesh = [], [], None
    for r in range(a.runs):
        iso_runs.append(run_isoloft(exe, stack, ply, report, a))
        target = iso_runs[0]["triangles"]
        if a.vtk_reduction == "match":
            reduction_for = lambda n: min(0.99, max(0.0, 1.0 - target / n))  # noqa: E731
        else:
            reduction_for = lambda n: float(a.vtk_reduction)  # noqa: E731
        res, vtk_mesh = run_vtk(files, a.z_spacing, reduction_for)
        vtk_runs.append(res)
        print("run %d/%d: isoloft %.2f s, vtk %.2f s" % (r + 1, a.runs, iso_runs[-1]["wall_s"], res["vtk_total_s"]),
              file=sys.stderr)

    vtk_ply = os.path.join(work, "vtk.ply")
    w = vtk.vtkPLYWriter()
    w.SetFileName(vtk_ply)
    w.SetInputData(vtk_mesh)
    w.Write()
    med = lambda runs, k: ic.median([x[k] for x in runs])  # noqa: E731
    iso_med = {"wall_s": med(iso_runs, "wall_s"),
               "stages_s": {k: ic.median([x["stages_s"][k] for x in iso_runs]) for k in iso_runs[0]["stages_s"]}}
    vtk_med = {k: med(vtk_runs, k) for k in ("vtk_extract_s", "vtk_surface_s", "vtk_decimate_s", "vtk_total_s")}
    iso_pts = ic.read_ply(ply)[0]
    vtk_pts = ns.vtk_to_numpy(vtk_mesh.GetPoints().GetData()).astype(np.float64)
    iso_box, vtk_box = bbox(iso_pts), bbox(vtk_pts)
    diff = [[abs(u - v) for u, v in zip(p, q)] for p, q in zip(iso_box, vtk_box)]
    iso_acc, vtk_acc = accuracy(exe, ply, stack), accuracy(exe, vtk_ply, stack)
    result = {
        "question": "isoloft vs vtkVoxelContoursToSurfaceFilter + vtkQuadricDecimation on the same contour stack",
        "input": {"shape": SHAPE, "size": a.size, "z_spacing": a.z_spacing, "slices": len(files),
                  "contour_polygons": vtk_runs[0]["contour_polygons"], "stack": stack},
        "runs": a.runs, "threads": a.threads, "machine": machine(),
        "isoloft": {"binary": exe, "decimate_error_px": a.decimate_error, "median": iso_med,
                    "triangles": iso_runs[-1]["triangles"],
                    "triangles_before_decimation": iso_runs[-1]["triangles_before_decimation"],
                    "closed_manifold": iso_runs[-1]["closed"] and iso_runs[-1]["manifold"],
                    "mesh": ply, "bbox_px": iso_box, "accuracy_vs_truth": iso_acc, "all_runs": iso_runs},
        "vtk": {"pipeline": "vtkPNGReader -> vtkFlyingEdges2D(127.5) -> vtkStripper -> polygons through contour "
                            "pixel centres, z = slice index -> vtkVoxelContoursToSurfaceFilter(spacing 1,1,zs) "
                            "-> z shift -> vtkCleanPolyData -> vtkQuadricDecimation",
                "decimation": ("target_reduction chosen per run to match isoloft's decimated triangle count"
                               if a.vtk_reduction == "match" else "fixed target_reduction %s" % a.vtk_reduction),
                "target_reduction": vtk_runs[-1]["target_reduction"],
                "timing_notes": "vtk_extract_s = PNG read + contour polygons; vtk_surface_s = filter + seam "
                                "merge; vtk_total_s = extract + surface + decimate (no file write)",
                "median": vtk_med, "triangles_surface": vtk_runs[-1]["triangles_surface"],
                "triangles": vtk_runs[-1]["triangles"], "mesh": vtk_ply, "bbox_px": vtk_box,
                "bbox_px_undecimated": vtk_runs[-1]["bbox_px_undecimated"], "accuracy_vs_truth": vtk_acc,
                "all_runs": vtk_runs},
        "ratio_vtk_total_over_isoloft_wall": vtk_med["vtk_total_s"] / iso_med["wall_s"],
        "ratio_vtk_total_over_isoloft_report_total": vtk_med["vtk_total_s"] / iso_med["stages_s"]["total"],
        # Both exclude file writing and decimation (isoloft's report total minus its decimate stage).
        "ratio_without_decimation": (vtk_med["vtk_extract_s"] + vtk_med["vtk_surface_s"])
        / (iso_med["stages_s"]["total"] - iso_med["stages_s"]["decimate"]),
        "bbox_max_abs_diff_px": {"xy": max(d[i] for d in diff for i in (0, 1)), "z": max(d[2] for d in diff)},
        "bbox_note": "VTK closes each end with a flat lid at the first/last contour slice; isoloft with a dome "
                     "up to half a spacing beyond it (README, End caps), so z differs by up to z_spacing/2 per end",
    }
    ic.write_json(a.out, result)

    print("vtk_side_by_side: %s %dx%d, %d slices, z spacing %g, %d threads, %d runs (medians)"
          % (SHAPE, a.size, a.size, len(files), a.z_spacing, a.threads, a.runs))
    print("  %-34s %9s %10s" % ("", "seconds", "triangles"))
    print("  %-34s %9.3f %10d" % ("isoloft (wall, incl. read/write)", iso_med["wall_s"], result["isoloft"]["triangles"]))
    print("  %-34s %9.3f" % ("  of which report total", iso_med["stages_s"]["total"]))
    print("  %-34s %9.3f" % ("vtk extract (read + polygons)", vtk_med["vtk_extract_s"]))
    print("  %-34s %9.3f %10d" % ("vtk surface (filter + merge)", vtk_med["vtk_surface_s"], result["vtk"]["triangles_surface"]))
    print("  %-34s %9.3f %10d" % ("vtk decimate", vtk_med["vtk_decimate_s"], result["vtk"]["triangles"]))
    print("  %-34s %9.3f" % ("vtk total", vtk_med["vtk_total_s"]))
    print("  ratio vtk total / isoloft wall: %.3f; without decimation (both): %.3f"
          % (result["ratio_vtk_total_over_isoloft_wall"], result["ratio_without_decimation"]))
    print("  bbox isoloft %s  vtk %s  (max diff xy %.2f px, z %.2f px: end caps)"
          % (iso_box, vtk_box, result["bbox_max_abs_diff_px"]["xy"], result["bbox_max_abs_diff_px"]["z"]))
    for name, acc in (("isoloft", iso_acc), ("vtk", vtk_acc)):
        t = acc["two_sided"]
        print("  %-7s vs truth: mean %.3f / %.3f px, p99 %.2f / %.2f px (mesh->truth / truth->mesh), normals %.1f deg"
              % (name, t["mesh_to_truth"]["mean_px"], t["truth_to_mesh"]["mean_px"], t["mesh_to_truth"]["p99_px"],
                 t["truth_to_mesh"]["p99_px"], t["mean_normal_angle_deg"]))
    print("  wrote %s" % a.out)


if __name__ == "__main__":
    main()
