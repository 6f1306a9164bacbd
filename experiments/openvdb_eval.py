#!/usr/bin/python3
"""Experiment (not a test; issue 37 item 2): OpenVDB's adaptive mesher
(tools::volumeToMesh, as pyopenvdb's FloatGrid.convertToPolygons) against
isoloft's own Marching Cubes + certified decimator, on isoloft's own field.

Per case, isoloft runs first: its undecimated Marching Cubes mesh with the
sampled field (`--volume`, float NRRD, pixels, positive inside), then whole
`reconstruct` runs at --decimate-error 0 and each --decimate-errors value
(--runs each; wall, max RSS, the report's mesh and decimate stage times,
triangles). Then each object's field goes into an OpenVDB FloatGrid (a narrow
band: the voxels within two of a sign change keep their values, the rest are
the background and signedFloodFill signs them, as a level set) and is meshed
at each --adaptivity, each run in a fresh process (peak RSS; OpenVDB's TBB
has the machine's cores, 2 here, as isoloft's --threads 2).

Every mesh is scored against the field at area-weighted random points on
the mesh plus its vertices (max and 95th percentile): |field| (trilinear in
the sampled volume, pixels times the pixel size = mm) and the first-order
distance to its zero set, |field| / |grad field| (mm). The field is an
in-plane distance interpolated in z, so across caps and nearly horizontal
walls |field| grows many times faster than the distance: the second is the
error in mm; every mesh also gets the Hausdorff distance to isoloft's
undecimated Marching Cubes mesh, the surface the decimator's bound is
certified against (points of each surface to the nearest of a few
candidate triangles of the other, found by a cKDTree on dense samples of
it), and a check: closed (every
edge twice), oriented (every edge once each way), vertex-manifold (one fan
per vertex), degenerate triangles and the minimum triangle angle (OpenVDB's
quads split along the shorter diagonal, its clockwise winding reversed to
isoloft's counter-clockwise).

Cases: jawbone (the frog skeleton stack of experiments/real_stack.py, 48
slices of 500 x 500 at 8:1), frog (the bundled example, scripts/example.sh's
command), rt (the shared RT Structure Set, a few ROIs), aal (the AAL atlas,
every 4th axial slice, a few labels).

usage: /usr/bin/python3 experiments/openvdb_eval.py [--isoloft build/isoloft] [--runs 3]
           [--cases jawbone,frog,rt,aal] [--adaptivity 0,0.1,0.25,0.5,1]
           [--decimate-errors 0.25,0.5,1] [--out DIR]
Needs python3-openvdb, python3-scipy, python3-nibabel: scripts/openvdb_eval.sh installs them
(ISOLOFT_EXTRA_PACKAGES for scripts/setup.sh, not the test set-up) and runs this.
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402
import speed_bench as sb  # noqa: E402

AAL = "/usr/share/mricron/templates/aal.nii.gz"
AAL_EVERY = 4  # every 4th axial slice kept, the others emptied (the sparse AAL case)
AAL_LABELS = "37,41,71,77"  # Hippocampus_L (thin curved), Amygdala_L (small), Caudate_L (thin C), Thalamus_L (compact)
RT_ROIS = ["Heart", "Lt Lung", "Tumor Bed"]  # smooth (33 planes), large (80 planes), small (18 planes)
BAND_VOXELS = 2  # narrow band kept around the sign changes: volumeToMesh reads the corners of crossing cells and their neighbours (gradients)
SAMPLES_PER_MESH = 100_000  # random surface points per scored mesh (plus its vertices)
TARGET_SAMPLES = 300_000  # dense samples of the other mesh for the Hausdorff's candidate search
CANDIDATES = 8  # nearest target samples whose triangles are measured exactly per query point
GRADIENT_FLOOR = 0.05  # |grad field| floor (mm/mm) for the first-order distance: the field is an in-plane distance (gradient ~1 across walls, larger across caps), so this only guards plateaus
ANGLE_THRESHOLDS = (1.0, 5.0, 10.0)  # degrees: triangles below each are counted (slivers)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--isoloft", default=ic.isoloft_exe())
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--cases", default="jawbone,frog,rt,aal")
    p.add_argument("--adaptivity", default="0,0.1,0.25,0.5,1")
    p.add_argument("--decimate-errors", default="0.25,0.5,1", help="isoloft --decimate-error values, px")
    p.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "openvdb"))
    p.add_argument("--rescore", action="store_true", help="only recompute the Hausdorff distances of --out's result.json")
    p.add_argument("--worker", nargs=3, metavar=("NRRD", "ADAPTIVITIES", "OUT_PREFIX"), help=argparse.SUPPRESS)
    return p.parse_args()


# ---------------------------------------------------------------- inputs

def aal_every4(out):
    path = os.path.join(out, "aal_every4.nii.gz")
    if not os.path.exists(path):
        import nibabel as nib
        aal = nib.load(AAL)
        labels = np.asarray(aal.dataobj).copy()
        labels[:, :, np.arange(labels.shape[2]) % AAL_EVERY != 0] = 0
        nib.save(nib.Nifti1Image(labels, aal.affine), path)
    return path


def case_args(case, out):
    if case == "rt":
        return [sb.RTSS] + [a for r in RT_ROIS for a in ("--roi", r)]
    if case == "aal":
        return [aal_every4(out), "--labels", AAL_LABELS]
    return sb.case_args(case, out)


# ---------------------------------------------------------------- field and geometry

def read_field(path):
    """The --volume NRRD: (field [x, y, z] float32 px, positive inside; origin (3,); axes (3, 3) columns = index steps, mm)."""
    a, h = ic.read_nrrd(path)
    if a.ndim == 2:
        a = a[None]
    origin = np.array(ic.nrrd_origin(h))
    dirs = [np.array([float(v) for v in d.strip("()").split(",")]) for d in h["space directions"].split()]
    return np.ascontiguousarray(a.transpose(2, 1, 0)), origin, np.column_stack(dirs)


def to_world(ijk, origin, axes):
    return ijk @ axes.T + origin


def to_index(xyz, origin, axes):
    return np.linalg.solve(axes, (xyz - origin).T).T


def triangulate(tris, quads, pts):
    """OpenVDB's triangles and quads as triangles, each quad split along its shorter diagonal."""
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    q = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    d02 = np.linalg.norm(pts[q[:, 0]] - pts[q[:, 2]], axis=1)
    d13 = np.linalg.norm(pts[q[:, 1]] - pts[q[:, 3]], axis=1)
    a = np.where((d02 <= d13)[:, None], q[:, [0, 1, 2]], q[:, [0, 1, 3]])
    b = np.where((d02 <= d13)[:, None], q[:, [0, 2, 3]], q[:, [1, 2, 3]])
    return np.vstack([tris, a, b])


# ---------------------------------------------------------------- OpenVDB worker (one fresh process per run)

def vdb_grid(f):
    """Field f ([x, y, z], positive inside) as an OpenVDB level set grid (negative inside) on a narrow band."""
    import pyopenvdb as vdb
    from scipy import ndimage
    t0 = time.perf_counter()
    inside = f > 0
    # Voxels whose 6-neighbour along some axis has the other sign, dilated by BAND_VOXELS.
    cross = np.zeros_like(inside)
    for ax in range(3):
        d = np.diff(inside, axis=ax)
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[ax], hi[ax] = slice(0, -1), slice(1, None)
        cross[tuple(lo)] |= d
        cross[tuple(hi)] |= d
    band = ndimage.maximum_filter(cross.view(np.uint8), size=2 * BAND_VOXELS + 1).view(bool)
    w = float(BAND_VOXELS + 1)  # background: beyond the band, outside
    a = np.where(band, -f, w).astype(np.float32)  # OpenVDB level sets are negative inside
    del inside, cross, band
    g = vdb.FloatGrid(w)
    g.copyFromArray(a, tolerance=0)
    del a
    g.signedFloodFill()
    g.gridClass = vdb.GridClass.LEVEL_SET
    return g, {"to_vdb_s": time.perf_counter() - t0, "grid_mem_mib": g.memUsage() / 2**20,
               "active_voxels": int(g.activeVoxelCount()), "dense_voxels": int(f.size)}


def worker(nrrd, adaptivities, out_prefix):
    """One object's field into a grid, meshed at each adaptivity (comma-separated); JSON on stdout; with an
    out_prefix other than '-', the meshes as out_prefix<adaptivity>.npz (world mm, counter-clockwise)."""
    f, origin, axes = read_field(nrrd)
    info = {"rss_field_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}
    g, grid_info = vdb_grid(f)
    del f
    info |= grid_info
    info["mesh"] = {}
    for ad in adaptivities.split(","):
        t0 = time.perf_counter()
        pts, tris, quads = g.convertToPolygons(isovalue=0.0, adaptivity=float(ad))
        info["mesh"][ad] = {"mesh_s": time.perf_counter() - t0, "triangles_native": int(len(tris)),
                            "quads_native": int(len(quads))}
        if out_prefix != "-":
            P = np.asarray(pts, dtype=np.float64)
            F = triangulate(tris, quads, P)
            # OpenVDB winds clockwise seen from outside (Houdini's convention); isoloft counter-clockwise.
            # A mirroring index-to-world map (det < 0) reverses it once more.
            F = F[:, ::-1] if np.linalg.det(axes) > 0 else F
            np.savez(out_prefix + ad + ".npz", points=to_world(P, origin, axes), faces=np.ascontiguousarray(F))
        del pts, tris, quads
    info["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps(info))


def run_worker(nrrd, adaptivities, out_prefix):
    r = ic.run(["/usr/bin/python3", os.path.abspath(__file__), "--worker", nrrd, adaptivities, out_prefix])
    return json.loads(r.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------- scoring

def areas(v, f):
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def sample_surface(v, f, n, rng):
    """n area-weighted random points on the mesh and their triangles, plus its vertices (at most n, triangle -1)."""
    a = areas(v, f)
    tri = rng.choice(len(f), size=n, p=a / a.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    p = (1 - s)[:, None] * v[f[tri, 0]] + (s * (1 - r2))[:, None] * v[f[tri, 1]] + (s * r2)[:, None] * v[f[tri, 2]]
    vv = v if len(v) <= n else v[rng.choice(len(v), size=n, replace=False)]
    return np.vstack([p, vv]), np.concatenate([tri, np.full(len(vv), -1)])


def field_error(v, f, field, origin, axes, rng):
    """The field at points on the mesh (trilinear in the sampled volume): |field| times the pixel size (mm), and
    the first-order distance to its zero set |field| / |grad field| (mm; the gradient by central differences of
    the trilinear field, half a voxel each side). Max, p95, mean of each."""
    from scipy import ndimage
    p, _ = sample_surface(v, f, SAMPLES_PER_MESH, rng)
    ijk = to_index(p, origin, axes)
    at = lambda q: ndimage.map_coordinates(field, q.T, order=1, mode="nearest")  # noqa: E731
    val = at(ijk)
    px = np.linalg.norm(axes[:, 0])  # mm per pixel: the field is in pixels
    g_index = np.stack([at(ijk + 0.5 * e) - at(ijk - 0.5 * e) for e in np.eye(3)], axis=1)  # d field / d index
    g_world = np.linalg.solve(axes.T, g_index.T).T * px  # d field(mm) / d mm
    raw = np.abs(val) * px
    dist = raw / np.maximum(np.linalg.norm(g_world, axis=1), GRADIENT_FLOOR)
    stats = lambda e: {"max_mm": float(e.max()), "p95_mm": float(np.percentile(e, 95)), "mean_mm": float(e.mean())}  # noqa: E731
    return {"distance": stats(dist), "raw": stats(raw)}


def one_sided(src, dst, rng):
    """Distances from points on mesh src to mesh dst (mm). Each point is measured exactly against the triangles
    of its CANDIDATES nearest samples of dst (an upper bound: a point whose closest triangle is not among them
    gets a longer distance); then the points with the largest bounds are measured against every triangle whose
    box is within their bound, until the largest exact distance is no smaller than the next bound, so the max
    (the Hausdorff distance) is exact. The percentiles are upper bounds."""
    from scipy.spatial import cKDTree
    from anatomy_metrics import closest_on_triangles  # exact point-triangle distance (Ericson)
    vs, fs = src
    vd, fd = dst
    p, _ = sample_surface(vs, fs, SAMPLES_PER_MESH, rng)
    q, qt = sample_surface(vd, fd, TARGET_SAMPLES, rng)
    # Every triangle's centroid too, so that slivers (no random sample) are candidates; vertex samples dropped.
    keep = qt >= 0
    q = np.vstack([q[keep], vd[fd].mean(axis=1)])
    qt = np.concatenate([qt[keep], np.arange(len(fd))])
    _, idx = cKDTree(q).query(p, k=CANDIDATES)
    best = np.full(len(p), np.inf)
    for j in range(CANDIDATES):
        t = fd[qt[idx[:, j]]]
        best = np.minimum(best, closest_on_triangles(p, vd[t[:, 0]], vd[t[:, 1]], vd[t[:, 2]]))
    lo, hi = vd[fd].min(axis=1), vd[fd].max(axis=1)
    order = np.argsort(-best)
    exact_max = 0.0
    for i in order:
        if exact_max >= best[i]:
            break
        box = np.linalg.norm(np.maximum(np.maximum(lo - p[i], p[i] - hi), 0.0), axis=1)
        t = fd[box <= best[i]]
        if len(t):
            pi = np.broadcast_to(p[i], (len(t), 3))
            best[i] = min(best[i], float(closest_on_triangles(pi, vd[t[:, 0]], vd[t[:, 1]], vd[t[:, 2]]).min()))
        exact_max = max(exact_max, best[i])
    return best


def hausdorff(mesh, mc, rng):
    """Both one-sided distances between a mesh and the Marching Cubes mesh: mc_to_mesh is the direction the
    decimator certifies (every point of the Marching Cubes surface within its error of the result)."""
    a, b = one_sided(mc, mesh, rng), one_sided(mesh, mc, rng)
    return {"hausdorff_mm": float(max(a.max(), b.max())), "mc_to_mesh_max_mm": float(a.max()),
            "mesh_to_mc_max_mm": float(b.max()), "mc_to_mesh_p95_mm": float(np.percentile(a, 95)),
            "mesh_to_mc_p95_mm": float(np.percentile(b, 95))}


def hausdorff_to_mc(meshes, mc, rng):
    """hausdorff() per object (0 for the Marching Cubes mesh itself); the worst of each entry over the objects."""
    keys = ("hausdorff_mm", "mc_to_mesh_max_mm", "mesh_to_mc_max_mm", "mc_to_mesh_p95_mm", "mesh_to_mc_p95_mm")

    def same(n):
        return all(a.shape == b.shape and np.array_equal(a, b) for a, b in zip(meshes[n], mc[n]))
    hd = {n: (dict.fromkeys(keys, 0.0) if same(n) else hausdorff(meshes[n], mc[n], rng)) for n in meshes}
    out = {k: max(h[k] for h in hd.values()) for k in keys}
    out["max_mm"] = out["hausdorff_mm"]
    out["per_object"] = hd
    return out


def mesh_check(v, f):
    """Closed, oriented, vertex-manifold, degenerate triangles, minimum angles (degrees)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    nf = len(f)
    he = np.stack([f, np.roll(f, -1, axis=1)], axis=2).reshape(-1, 2)  # half-edges (a -> b), face = index // 3
    key = np.minimum(he[:, 0], he[:, 1]) * len(v) + np.maximum(he[:, 0], he[:, 1])
    order = np.argsort(key, kind="stable")
    k = key[order]
    _, start, count = np.unique(k, return_index=True, return_counts=True)
    closed = bool(np.all(count == 2))
    two = start[count == 2]
    h1, h2 = order[two], order[two + 1]
    oriented = closed and bool(np.all(he[h1, 0] == he[h2, 1]))
    # Corner c of face t at vertex v: node 3 t + c. Across each edge shared by two faces, join the corners at its ends.
    def corner(h, vert):
        t = h // 3
        return 3 * t + np.argmax(f[t] == vert[:, None], axis=1)
    rows, cols = [], []
    for end in (0, 1):
        vert = he[h1, end]
        rows.append(corner(h1, vert))
        cols.append(corner(h2, vert))
    r, c = np.concatenate(rows), np.concatenate(cols)
    g = coo_matrix((np.ones(len(r)), (r, c)), shape=(3 * nf, 3 * nf))
    _, lab = connected_components(g, directed=False)
    fans = np.unique(np.stack([f.ravel(), lab]), axis=1)[0]
    fans_per_vertex = np.bincount(fans, minlength=len(v))
    used = fans_per_vertex > 0
    # Angles.
    e = [v[f[:, (i + 1) % 3]] - v[f[:, i]] for i in range(3)]
    L = np.stack([np.linalg.norm(x, axis=1) for x in e], axis=1)
    ang = []
    for i in range(3):
        u, w = e[i], -e[(i + 2) % 3]
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.einsum("ij,ij->i", u, w) / (L[:, i] * L[:, (i + 2) % 3])
        ang.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    amin = np.nanmin(np.stack(ang, axis=1), axis=1)
    degenerate = (areas(v, f) <= 1e-12 * max(1.0, float(L.max()) ** 2)) | np.isnan(amin)
    vol = float(np.sum(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])))) / 6.0
    out = {"closed": closed, "oriented": oriented, "outward": vol > 0, "signed_volume": vol, "nonmanifold_edges": int(np.sum(count != 2)),
           "nonmanifold_vertices": int(np.sum(fans_per_vertex[used] > 1)), "unused_vertices": int(np.sum(~used)),
           "degenerate_triangles": int(degenerate.sum()),
           "min_angle_deg": float(np.nanmin(amin)) if nf else None,
           "p1_min_angle_deg": float(np.nanpercentile(amin, 1)) if nf else None}
    for t in ANGLE_THRESHOLDS:
        out[f"below_{t:g}deg"] = int(np.sum((amin < t) | degenerate))
    return out


# ---------------------------------------------------------------- isoloft

def isoloft_runs(exe, args, err, runs, threads, work):
    """--runs whole reconstruct processes at --decimate-error err: medians and the last run's meshes."""
    rs = []
    for _ in range(runs):
        r, rep = sb.run_cli(exe, "", args, threads, work, ["--decimate-error", "%g" % err])
        rs.append(r)
    med = {k: ic.median([r[k] for r in rs]) for k in ("wall_s", "cpu_s", "max_rss_mib")}
    for st in ("mesh", "decimate", "interp"):
        med[st + "_s"] = ic.median([r["stages_s"][st] for r in rs])
    med["triangles"] = rs[-1]["triangles"]
    med["files"] = {str(o.get("roi", o.get("label"))): o["file"] for o in rep["objects"]}
    med["runs"] = [{k: r[k] for k in ("wall_s", "max_rss_mib")} | {"stages_s": r["stages_s"]} for r in rs]
    return med


def load_ply(path):
    v, f, _ = ic.read_ply(path)
    return v, f


# ---------------------------------------------------------------- main

def evaluate_case(a, case, exe, adapt, errs, rng):
    work = os.path.join(a.out, case)
    os.makedirs(work, exist_ok=True)
    args = case_args(case, a.out)
    # The field and the undecimated Marching Cubes meshes (untimed).
    d = tempfile.mkdtemp(dir=work)
    rep_path = os.path.join(d, "r.json")
    ic.run([exe, "reconstruct", *args, "-o", os.path.join(d, "m.ply"), "--volume", os.path.join(d, "field.nrrd"),
            "--report", rep_path, "--threads", str(a.threads), "-q", "--decimate-error", "0"])
    rep = ic.read_json(rep_path)
    objects = []
    for o in rep["objects"]:
        suffix = os.path.basename(o["file"])[1:-4]  # m<suffix>.ply -> <suffix>
        vol = os.path.join(d, "field" + suffix + ".nrrd")
        if not os.path.exists(vol):
            raise RuntimeError(f"{case}: no field for {o['file']} (looked for {vol})")
        objects.append((str(o.get("roi", o.get("label"))), o["file"], vol))
    res = {"args": args, "objects": [n for n, _, _ in objects], "field_dir": d,
           "mc_files": {n: m for n, m, _ in objects}, "isoloft": {}, "openvdb": {}}
    fields = {n: read_field(vol) for n, _, vol in objects}
    mc = {n: load_ply(m) for n, m, _ in objects}

    def score(r, meshes):
        """Field error, Hausdorff to the Marching Cubes mesh, mesh check; worst over the objects."""
        per = {n: field_error(*meshes[n], *fields[n], rng) for n in meshes}
        r["triangles"] = int(sum(len(m[1]) for m in meshes.values()))
        r["error"] = {k: {"max_mm": max(p[k]["max_mm"] for p in per.values()),
                          "p95_mm_worst": max(p[k]["p95_mm"] for p in per.values())} for k in ("distance", "raw")}
        r["error"]["per_object"] = per
        r["hausdorff_to_mc"] = hausdorff_to_mc(meshes, mc, rng)
        r["check"] = {n: mesh_check(*meshes[n]) for n in meshes}

    res["pixel_mm"] = {n: float(np.linalg.norm(fields[n][2][:, 0])) for n in fields}
    for err in [0.0] + errs:
        print(f"  {case}: isoloft --decimate-error {err:g}", flush=True)
        r = isoloft_runs(exe, args, err, a.runs, a.threads, work)
        score(r, {n: load_ply(r["files"][n]) for n, _, _ in objects})
        res["isoloft"]["%g" % err] = r
    print(f"  {case}: openvdb", flush=True)
    ads = ",".join("%g" % ad for ad in adapt)
    prefix = {n: os.path.join(d, f"vdb_{n.replace(' ', '_')}_") for n, _, _ in objects}
    runs = [{n: run_worker(vol, ads, prefix[n] if i == 0 else "-") for n, _, vol in objects} for i in range(a.runs)]
    for ad in adapt:
        key = "%g" % ad
        r = {"mesh_s": ic.median([sum(p["mesh"][key]["mesh_s"] for p in rr.values()) for rr in runs]),
             "to_vdb_s": ic.median([sum(p["to_vdb_s"] for p in rr.values()) for rr in runs]),
             "peak_rss_mib": ic.median([max(p["peak_rss_mib"] for p in rr.values()) for rr in runs]),
             "rss_field_mib": max(p["rss_field_mib"] for p in runs[0].values()),
             "grid_mem_mib": sum(p["grid_mem_mib"] for p in runs[0].values()),
             "active_voxels": sum(p["active_voxels"] for p in runs[0].values()),
             "dense_voxels": sum(p["dense_voxels"] for p in runs[0].values()),
             "mesh_runs_s": [sum(p["mesh"][key]["mesh_s"] for p in rr.values()) for rr in runs]}
        meshes = {}
        for n, _, _ in objects:
            z = np.load(prefix[n] + key + ".npz")
            meshes[n] = (z["points"], z["faces"])
        score(r, meshes)
        res["openvdb"][key] = r
    return res


def table(results):
    lines = ["| case | mesher | setting | triangles | mesh (+decimate) s | peak MiB | distance max / p95 mm "
             "| \\|f\\| max mm | MC to mesh max mm | mesh to MC max / p95 mm | closed, manifold | min angle deg | < 5 deg |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|"]

    def row(case, who, setting, r, time_s, mem):
        ch = r["check"].values()
        ok = all(c["closed"] and c["oriented"] and c["outward"] and c["nonmanifold_vertices"] == 0 for c in ch)
        e, h = r["error"], r["hausdorff_to_mc"]
        return (f"| {case} | {who} | {setting} | {r['triangles']:,} | {time_s} | {mem} "
                f"| {e['distance']['max_mm']:.3f} / {e['distance']['p95_mm_worst']:.3f} | {e['raw']['max_mm']:.2f} "
                f"| {h['mc_to_mesh_max_mm']:.3f} | {h['mesh_to_mc_max_mm']:.3f} / {h['mesh_to_mc_p95_mm']:.3f} | {'yes' if ok else 'NO'} "
                f"| {min(c['min_angle_deg'] for c in ch):.2f} | {sum(c['below_5deg'] for c in ch):,} |")

    for case, res in results.items():
        for err, r in res["isoloft"].items():
            lines.append(row(case, "isoloft MC" + (" + decimate" if err != "0" else ""), f"e={err} px", r,
                             f"{r['mesh_s'] + r['decimate_s']:.3f} (wall {r['wall_s']:.2f})", f"{r['max_rss_mib']:.0f}"))
        for ad, r in res["openvdb"].items():
            lines.append(row(case, "OpenVDB", f"a={ad}", r, f"{r['mesh_s']:.3f} (+{r['to_vdb_s']:.2f} to VDB)",
                             f"{r['peak_rss_mib']:.0f} (grid {r['grid_mem_mib']:.0f})"))
    return "\n".join(lines) + "\n"


def rescore(a):
    """Recomputes the Hausdorff distances of a finished --out (its meshes still on disk), then the table."""
    import glob
    path = os.path.join(a.out, "result.json")
    results = ic.read_json(path)
    rng = np.random.default_rng(37)
    for case, res in results.items():
        d = res.get("field_dir") or os.path.dirname(glob.glob(os.path.join(a.out, case, "*", "field*.nrrd"))[0])
        rep = ic.read_json(os.path.join(d, "r.json"))
        mc = {str(o.get("roi", o.get("label"))): load_ply(o["file"]) for o in rep["objects"]}
        print(f"openvdb_eval: rescoring {case}", flush=True)
        for r in res["isoloft"].values():
            r["hausdorff_to_mc"] = hausdorff_to_mc({n: load_ply(f) for n, f in r["files"].items()}, mc, rng)
        for key, r in res["openvdb"].items():
            meshes = {}
            for n in mc:
                z = np.load(os.path.join(d, f"vdb_{n.replace(' ', '_')}_{key}.npz"))
                meshes[n] = (z["points"], z["faces"])
            r["hausdorff_to_mc"] = hausdorff_to_mc(meshes, mc, rng)
        ic.write_json(path, results)
    ic.write_text(os.path.join(a.out, "table.md"), table(results))
    print(table(results))


def main():
    a = parse_args()
    if a.worker:
        worker(*a.worker)
        return
    if a.rescore:
        rescore(a)
        return
    try:
        import pyopenvdb  # noqa: F401
        import scipy  # noqa: F401
    except ImportError as e:
        sys.exit(f"openvdb_eval: {e.name} not installed (scripts/openvdb_eval.sh installs python3-openvdb, python3-scipy)")
    exe = os.path.abspath(a.isoloft)
    if not os.access(exe, os.X_OK):
        sys.exit(f"openvdb_eval: isoloft binary not found at {exe} (build it: scripts/setup.sh)")
    os.makedirs(a.out, exist_ok=True)
    adapt = [float(x) for x in a.adaptivity.split(",")]
    errs = [float(x) for x in a.decimate_errors.split(",") if x]
    rng = np.random.default_rng(37)
    results = {}
    for case in a.cases.split(","):
        print(f"openvdb_eval: {case}", flush=True)
        results[case] = evaluate_case(a, case, exe, adapt, errs, rng)
        ic.write_json(os.path.join(a.out, "result.json"), results)
        ic.write_text(os.path.join(a.out, "table.md"), table(results))
    print(table(results))


if __name__ == "__main__":
    main()
