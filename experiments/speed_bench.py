#!/usr/bin/python3
"""Benchmark (not a test; issue 24): isoloft at the scale users bring, with
VTK's filter on the same jawbone-scale stack in the same run.

Cases (each a whole `isoloft reconstruct` process, 2 threads by default):
  rt       the shared RT Structure Set, every ROI (../shared/data/rtstruct/rtss.dcm)
  jawbone  the jawbone-scale real stack (experiments/real_stack.py: frog
           skeleton, 48 slices of 500x500 at 8:1)
  P        the reproduction's P set with the paper's method (marker2006; RT-STRUCT Lt Lung, 34 planes fitted at
           2000x2000; experiments/reproduce_data.py)
  frog     the bundled example (scripts/example.sh's command)
  vtk      vtkVoxelContoursToSurfaceFilter alone on the jawbone stack's
           contours (in this process; building its input polygons untimed),
           two ways (vtk_inputs: at the pixel spacing, and the leaderboard's
           doubled pixel-edge polygons, "vtk2x")

Runs alternate case by case (and, with --before, the old and new CLI back to
back) --runs times each; medians of wall, CPU, max RSS and the report's
stage times, triangle counts (largest mesh and all), and the ratios new/old
and jawbone/VTK. The RT case's Heart, Lt Lung and BODY meshes are scored against
their contour vertices (mean, p95, max mm; vertices of loops the working
grid drops, under one pixel, are left out as the reader leaves them out).
Writes JSON and a Markdown table.

Needs python3-pydicom for the P case (ISOLOFT_EXTRA_PACKAGES=python3-pydicom
scripts/setup.sh --full, as scripts/reproduce.sh does) and python3-vtk9.

usage: /usr/bin/python3 experiments/speed_bench.py [--isoloft build/isoloft] [--before OLD_CLI]
           [--runs 5] [--threads 2] [--cases rt,jawbone,P,frog,vtk] [--out DIR] [-- extra isoloft args]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402

SHARED = os.path.normpath(os.path.join(ic.ROOT, "..", "shared", "data"))
RTSS = os.path.join(SHARED, "rtstruct", "rtss.dcm")
FROG_MHD = os.path.join(SHARED, "frog", "frogtissue.mhd")
SCORED_ROIS = ["Heart", "Lt Lung", "BODY"]
STAGES = ["read", "contour", "mpu", "dist", "filter", "interp", "mesh", "decimate", "write"]


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--isoloft", default=ic.isoloft_exe())
    p.add_argument("--before", help="an older isoloft CLI, run back to back with --isoloft")
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--cases", default="rt,jawbone,P,frog,vtk")
    p.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "speed"))
    p.add_argument("extra", nargs="*", help="extra arguments for the new CLI (after --)")
    return p.parse_args()


# ---------------------------------------------------------------- inputs

def jawbone_stack(out):
    path = os.path.join(out, "jawbone.mha")
    if not os.path.exists(path):
        ic.run(["/usr/bin/python3", os.path.join(ic.ROOT, "experiments", "real_stack.py"), FROG_MHD, path])
    return path


def p_set(out):
    path = os.path.join(out, "data", "P", "lt_lung.txt")
    if not os.path.exists(path):
        import reproduce_data
        import rtstruct
        reproduce_data.make_p(os.path.join(out, "data"), rtstruct.read_rtstruct(RTSS))
    return path


def case_args(case, out):
    if case == "rt":
        return [RTSS]
    if case == "jawbone":
        return [jawbone_stack(out)]
    if case == "P":
        return [p_set(out), "--method", "marker2006", "--raster-resolution", "2000"]
    if case == "frog":
        return [os.path.join(ic.ROOT, "data", "frog"), "--input", "labels", "--z-spacing", "6", "--pixel-size", "1"]
    raise ValueError(case)


# ---------------------------------------------------------------- isoloft runs

def run_cli(exe, case, args, threads, work, extra):
    """One reconstruct process: wall, CPU, max RSS, stage times, triangles."""
    d = tempfile.mkdtemp(dir=work)
    out, report, timing = os.path.join(d, "m.ply"), os.path.join(d, "r.json"), os.path.join(d, "time.txt")
    cmd = ["/usr/bin/time", "-f", "%e %U %S %M", "-o", timing, exe, "reconstruct", *args, "-o", out,
           "--report", report, "--threads", str(threads), "-q", *extra]
    t0 = time.perf_counter()
    ic.run(cmd)
    wall = time.perf_counter() - t0
    e, u, s, m = open(timing).read().split()[-4:]
    rep = ic.read_json(report)
    times = rep["timings_s"]
    objs = rep.get("objects", [])
    tri = [int(o["triangles"]) for o in objs]
    res = {"wall_s": wall, "cpu_s": float(u) + float(s), "max_rss_mib": int(m) / 1024.0,
           "stages_s": {k: float(times.get(k, 0.0)) for k in STAGES},
           "triangles": int(sum(tri)), "max_mesh_triangles": int(max(tri) if tri else 0),
           "per_object": {str(o.get("roi", o.get("label"))): int(o["triangles"]) for o in objs},
           "dir": d}
    return res, rep


def roi_file(report, roi):
    for o in report["objects"]:
        if o.get("roi") == roi:
            return o["file"]
    raise KeyError(roi)


def vertex_scores(report, roi_planes, rois):
    """Contour vertices to mesh distances (mm) of the scored ROIs."""
    import vtk
    from vtk.util import numpy_support as ns
    out = {}
    for roi in rois:
        v, f, _ = ic.read_ply(roi_file(report, roi))
        pts = vtk.vtkPoints()
        pts.SetData(ns.numpy_to_vtk(v, deep=1))
        cells = vtk.vtkCellArray()
        cells.SetData(ns.numpy_to_vtkIdTypeArray(np.arange(0, 3 * len(f) + 1, 3, dtype=np.int64), deep=1),
                      ns.numpy_to_vtkIdTypeArray(f.ravel().astype(np.int64), deep=1))
        pd = vtk.vtkPolyData()
        pd.SetPoints(pts)
        pd.SetPolys(cells)
        loc = vtk.vtkStaticCellLocator()
        loc.SetDataSet(pd)
        loc.BuildLocator()
        voxel = grid_mm(report, roi)
        d = []
        closest, cid, sub, d2 = [0.0, 0.0, 0.0], vtk.reference(0), vtk.reference(0), vtk.reference(0.0)
        for z, polys in roi_planes[roi].items():
            for q in polys:
                area = 0.5 * abs(np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]))
                if area < voxel * voxel:
                    continue  # dropped by the reader: under one pixel of the working grid
                for x, y in q:
                    loc.FindClosestPoint([x, y, z], closest, cid, sub, d2)
                    d.append(float(d2) ** 0.5)
        d = np.array(d)
        out[roi] = {"vertices": int(len(d)), "voxel_mm": voxel, "mean_mm": float(d.mean()),
                    "p95_mm": float(np.percentile(d, 95)), "max_mm": float(d.max())}
    return out


def grid_mm(report, roi):
    """The ROI's working grid, mm (input.rois[].pixel_size if the report has it)."""
    for r in report["input"].get("rois", []):
        if r["name"] == roi and "pixel_size" in r:
            return float(r["pixel_size"])
    return float(report["input"]["pixel_size"])


# ---------------------------------------------------------------- VTK

def vtk_inputs(stack_path):
    """The jawbone stack's annotated slices as vtkVoxelContoursToSurfaceFilter
    input, two ways: "vtk", polygons through the mask's boundary pixel centres
    at the pixel spacing (experiments/vtk_side_by_side.py's rule; the grid of
    isoloft's fields); "vtk2x", polygons along the mask's pixel edges with
    doubled coordinates and SetSpacing(0.5, 0.5, step) (the leaderboard's rule,
    experiments/anatomy_peers.py: 4x the pixels). {name: (polydata, spacing)}."""
    import anatomy_peers as ap
    import vtk_side_by_side as vs
    head, off = {}, 0
    with open(stack_path, "rb") as f:
        data = f.read()
    for line in data.split(b"\n"):
        off += len(line) + 1
        k, _, v = line.decode().partition(" = ")
        head[k] = v
        if k == "ElementDataFile":
            break
    nx, ny, nz = map(int, head["DimSize"].split())
    vol = np.frombuffer(data, np.uint8, count=nx * ny * nz, offset=off).reshape(nz, ny, nx)
    kept = [k for k in range(nz) if vol[k].any()]
    steps = set(np.diff(kept).tolist())
    assert len(steps) == 1, steps
    step = float(steps.pop())
    centres, edges = [], []
    for k in kept:
        m = vol[k] > 0
        inner = np.pad(m, 1)
        inner = inner[1:-1, 1:-1] & inner[:-2, 1:-1] & inner[2:, 1:-1] & inner[1:-1, :-2] & inner[1:-1, 2:]
        centres.append(vs.white_polygons(m & ~inner))
        edges.append([np.rint(2.0 * q) for q in ap._slice_polygons(m)])
    return {"vtk": (ap.polygons_polydata(centres), (1.0, 1.0, step)),
            "vtk2x": (ap.polygons_polydata(edges), (0.5, 0.5, step))}


def run_vtk_filter(contours, spacing):
    import vtk
    f = vtk.vtkVoxelContoursToSurfaceFilter()
    f.SetInputData(contours)
    f.SetSpacing(*spacing)
    f.SetMemoryLimitInBytes(1 << 30)
    t0 = time.perf_counter()
    f.Update()
    wall = time.perf_counter() - t0
    return {"wall_s": wall, "triangles": int(f.GetOutput().GetNumberOfPolys())}


# ---------------------------------------------------------------- table

def med(runs, key):
    return ic.median([r[key] for r in runs])


def summarize(results):
    s = {}
    for name, runs in results.items():
        if not runs:
            continue
        if name.startswith("vtk"):
            s[name] = {"wall_s": med(runs, "wall_s"), "triangles": runs[0]["triangles"], "runs": len(runs)}
            continue
        s[name] = {"wall_s": med(runs, "wall_s"), "cpu_s": med(runs, "cpu_s"), "max_rss_mib": med(runs, "max_rss_mib"),
                   "stages_s": {k: ic.median([r["stages_s"][k] for r in runs]) for k in STAGES},
                   "triangles": runs[0]["triangles"], "max_mesh_triangles": runs[0]["max_mesh_triangles"],
                   "per_object": runs[0]["per_object"], "runs": len(runs),
                   "all_wall_s": [round(r["wall_s"], 3) for r in runs]}
    return s


def table(s, cases, before):
    lines = ["| case | CLI | wall s | CPU s | max RSS MiB | " + " | ".join(STAGES) + " | triangles (largest mesh) |",
             "|" + "---|" * (len(STAGES) + 6)]
    for c in cases:
        if c == "vtk":
            continue
        for who in (["before", "after"] if before else ["after"]):
            r = s.get(who + ":" + c)
            if not r:
                continue
            lines.append(f"| {c} | {who} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | {r['max_rss_mib']:.0f} | "
                         + " | ".join(f"{r['stages_s'][k]:.2f}" for k in STAGES)
                         + f" | {r['triangles']:,} ({r['max_mesh_triangles']:,}) |")
    lines += ["", "| ratio | value |", "|---|---|"]
    for c in cases:
        if c != "vtk" and before and "before:" + c in s and "after:" + c in s:
            lines.append(f"| {c}: after / before wall | {s['after:' + c]['wall_s'] / s['before:' + c]['wall_s']:.3f} |")
    for v in ("vtk", "vtk2x"):
        if v not in s:
            continue
        for who in (["before", "after"] if before else ["after"]):
            if who + ":jawbone" in s:
                lines.append(f"| jawbone {who} / {v} filter wall ({v} {s[v]['wall_s']:.3f} s, {s[v]['triangles']:,} "
                             f"triangles) | {s[who + ':jawbone']['wall_s'] / s[v]['wall_s']:.2f} |")
    return "\n".join(lines)


def main():
    a = parse_args()
    os.makedirs(a.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="speed_bench_", dir=a.out)
    cases = a.cases.split(",")
    clis = [("after", a.isoloft, a.extra)]
    if a.before:
        clis.insert(0, ("before", a.before, []))
    args = {c: case_args(c, a.out) for c in cases if c != "vtk"}
    vtk_in = vtk_inputs(jawbone_stack(a.out)) if "vtk" in cases else {}
    results = {f"{who}:{c}": [] for who, _, _ in clis for c in cases if c != "vtk"}
    results.update({name: [] for name in vtk_in})
    scores = {}
    for r in range(a.runs):
        for c in cases:
            if c == "vtk":
                for name, inp in vtk_in.items():
                    results[name].append(run_vtk_filter(*inp))
                    print(f"run {r + 1}: {name} {results[name][-1]['wall_s']:.3f} s", flush=True)
                continue
            order = clis if r % 2 == 0 else clis[::-1]
            for who, exe, extra in order:
                res, rep = run_cli(exe, c, args[c], a.threads, work, extra)
                if c == "rt" and r == 0:
                    import rtstruct
                    scores[who] = vertex_scores(rep, rtstruct.read_rtstruct(RTSS), SCORED_ROIS)
                results[f"{who}:{c}"].append(res)
                subprocess.run(["rm", "-rf", res.pop("dir")])
                print(f"run {r + 1}: {who} {c} {res['wall_s']:.2f} s, {res['max_rss_mib']:.0f} MiB, "
                      f"{res['triangles']:,} triangles", flush=True)
    s = summarize(results)
    doc = {"runs": a.runs, "threads": a.threads, "cli": {who: exe for who, exe, _ in clis}, "extra": a.extra,
           "summary": s, "rt_vertex_to_mesh": scores, "all": results, "load_avg": os.getloadavg()}
    ic.write_json(os.path.join(a.out, "speed_bench.json"), doc)
    text = table(s, cases, bool(a.before))
    for who, sc in scores.items():
        text += "\n\n" + who + ": RT contour vertices to mesh (mm): " + ", ".join(
            f"{roi} mean {v['mean_mm']:.3f} p95 {v['p95_mm']:.3f} max {v['max_mm']:.3f} ({v['vertices']} vertices, grid {v['voxel_mm']:g} mm)"
            for roi, v in sc.items())
    ic.write_text(os.path.join(a.out, "speed_bench.md"), text + "\n")
    subprocess.run(["rm", "-rf", work])
    print(text)


if __name__ == "__main__":
    main()
