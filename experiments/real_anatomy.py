#!/usr/bin/python3
"""Question: on real anatomy, how close does each system's surface from every
k-th slice come to the truth, and which isoloft stage gains or loses what?

Cases: frog organs and AAL structures (CASES), k = 2, 4, 8, two truths:
  staircase  the dense mask smoothed by a Gaussian of 0.7 mm, level 0.5: the
             segmentation as drawn (per-slice jaggedness kept); input = the
             original mask slices. What a user's own labels say.
  smooth     the dense mask smoothed by 1.5 mm, level 0.5; input = that
             truth's own cross-sections. A smooth anatomy-shaped surface whose
             input is exactly consistent with it: a method's interpolation
             error without the segmentation's z noise.
Every system gets the same input slices (the non-empty kept slices and the
empty ones between them) and is scored by anatomy_metrics.evaluate inside the
slice range. isoloft runs as the CLI on mask PNGs (`--input masks`, and
contour images / polylines in the ablation); the peers are anatomy_peers.py.
Structures are cropped to their bounding box + CROP_PAD so a full run stays
under ~45 min on 2 cores.

usage: real_anatomy.py [--out DIR] [--cases frog:14,aal:41] [--ks 2,4,8]
         [--truths staircase,smooth] [--systems a,b] [--no-ablation] [--ablation-ks 4] [--threads 2]
         [--redo a,b] [--add NAME=COMMAND | NAME=DIR] [--keep-meshes]
Rows are appended to OUT/rows.jsonl; a row already there is not rerun
unless its system is in --redo (or --fresh), so after a change to isoloft
`--redo isoloft` reruns only the isoloft rows. Bring your own method:
  --add 'mine=my_tool {masks_dir} --z {slice_z} -o {out}'   a command; placeholders
        {masks_dir} (PNG 0/255 per input slice, in z order), {contours_dir},
        {polylines} (isoloft polyline text), {slice_z} (comma list, mm),
        {out} (PLY/OBJ/STL to write, mm, x = column, y = row of the crop)
  --add 'mine=/path/meshes'  a folder of meshes named {case_id}.ply
        (OUT/inputs/{case_id}/ holds the same inputs, written on the first run)
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
from scipy import ndimage

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import anatomy_metrics as am  # noqa: E402
import anatomy_peers as peers  # noqa: E402
import isoloft_common as ic  # noqa: E402

FROG = os.environ.get("FROG", "/work/shared/data/frog/frogtissue.mhd")
AAL = os.environ.get("AAL", "/usr/share/mricron/templates/aal.nii.gz")
# (dataset, label, name, why it is in): small to large, thin and branching.
CASES = [
    ("aal", 41, "Amygdala_L", "small compact (1.7k voxels)"),
    ("frog", 14, "spleen", "small, 4 pieces (3.9k)"),
    ("aal", 37, "Hippocampus_L", "thin curved"),
    ("aal", 71, "Caudate_L", "thin C-shaped"),
    ("aal", 73, "Putamen_L", "compact"),
    ("aal", 77, "Thalamus_L", "compact"),
    ("aal", 91, "Cerebelum_Crus1_L", "large folded (21k)"),
    ("frog", 2, "brain", "elongated (19k)"),
    ("frog", 5, "eye_white", "thin shell, 6 pieces"),
    ("frog", 3, "duodenum", "thin tube"),
    ("frog", 6, "heart", "compact (37k)"),
    ("frog", 8, "kidney", "branching, 3 pieces"),
    ("frog", 11, "lung", "branching, 7 pieces"),
    ("frog", 10, "liver", "large, lobed (205k)"),
]
TRUTH_SIGMA_MM = {"staircase": 0.7, "smooth": 1.5}
# In-plane crop margin: > 3 sigma of the smooth truth (4.5 mm) plus 2 px for
# the reconstructions' rims; in z, slices up to 3 sigma beyond the structure.
CROP_PAD = 7
ISOLOFT_SYSTEMS = {
    "isoloft-default": [],  # whatever `isoloft reconstruct` does without --method
    "marker2006-monotone": ["--method", "marker2006", "--spline", "monotone"],
    "marker2006-catmull-rom": ["--method", "marker2006", "--spline", "catmull-rom"],
    "marker2006-natural": ["--method", "marker2006", "--spline", "natural"],
    "marker2006-linear": ["--method", "marker2006", "--spline", "linear"],
    "marker2006-no-filter": ["--method", "marker2006", "--no-filter"],
    "levin-monotone": ["--method", "levin", "--spline", "monotone"],
    "levin-linear": ["--method", "levin", "--spline", "linear"],
    "field3d": ["--method", "field3d"],  # one 3D field from every input slice (issue 35)
}
PEER_SYSTEMS = ["nearest", "vtk", "mci", "slicerrt"]
# Ablation variants of marker2006 (defaults otherwise; the spline, filter and
# levin rows above are the rest of it): (input kind, extra args).
ABLATION = {
    "abl-contour-images": ("contours", ["--method", "marker2006"]),
    "abl-polylines": ("polylines", ["--method", "marker2006"]),
    "abl-n-min-50": ("masks", ["--method", "marker2006", "--n-min", "50"]),
    "abl-n-min-300": ("masks", ["--method", "marker2006", "--n-min", "300"]),
    "abl-tol-0.35": ("masks", ["--method", "marker2006", "--tol", "0.35"]),
    "abl-tol-1.5": ("masks", ["--method", "marker2006", "--tol", "1.5"]),
    # The paper's Table 2 for J (N_min 250, tol 10), tol read as 10 x 1e-4 of
    # the slice image's diagonal (reproduce_tables.py PAPER_TOL_UNIT): 0.69 px
    # on the frog's 500 x 470, 0.28 px on AAL's 181 x 217.
    "abl-paper-table2-J": ("masks", ["--method", "marker2006", "--n-min", "250", "--tol", "{paper_tol_10}"]),
}
PAPER_TOL_UNIT = 1e-4


def load_volume(dataset):
    """(labels (nz, ny, nx), z spacing mm); both have 1 mm square pixels."""
    if dataset == "frog":
        vol, sp = ic.read_frog(FROG)
        assert sp[0] == sp[1] == 1.0
        return vol, sp[2]
    import nibabel as nib
    img = nib.load(AAL)
    assert tuple(float(s) for s in img.header.get_zooms()[:3]) == (1.0, 1.0, 1.0)
    return np.ascontiguousarray(np.asarray(img.dataobj).transpose(2, 1, 0)), 1.0


def crop(mask, pad_xy, pad_z):
    """The structure's bounding box plus margins (zero-padded past the volume).
    Returns (crop, z index of crop slice 0 in the volume)."""
    idx = [np.nonzero(mask.any(axis=a))[0] for a in ((1, 2), (0, 2), (0, 1))]
    lo = [idx[0][0] - pad_z, idx[1][0] - pad_xy, idx[2][0] - pad_xy]
    hi = [idx[0][-1] + pad_z + 1, idx[1][-1] + pad_xy + 1, idx[2][-1] + pad_xy + 1]
    src = tuple(slice(max(l, 0), min(h, n)) for l, h, n in zip(lo, hi, mask.shape))
    out = np.zeros([h - l for l, h in zip(lo, hi)], bool)
    dst = tuple(slice(s.start - l, s.stop - l) for s, l in zip(src, lo))
    out[dst] = mask[src]
    return out, lo[0]


def write_png(path, mask):
    from PIL import Image
    Image.fromarray(mask.astype(np.uint8) * 255).save(path)


def write_inputs(d, inp, kept, dz):
    """Mask PNGs, contour PNGs (mask_boundary: mask pixels with a 4-neighbour
    outside) and polylines (traced at the half-pixel) of the input slices."""
    os.makedirs(os.path.join(d, "masks"), exist_ok=True)
    os.makedirs(os.path.join(d, "contours"), exist_ok=True)
    slices = []
    for i, z in enumerate(kept):
        m = inp[z]
        write_png(os.path.join(d, "masks", "s%03d.png" % i), m)
        inner = ndimage.binary_erosion(m, structure=ndimage.generate_binary_structure(2, 1), border_value=0)
        write_png(os.path.join(d, "contours", "s%03d.png" % i), m & ~inner)
        slices.append((z * dz, [p for p in peers.trace_polygons(m)]))
    ny, nx = inp.shape[1:]
    ic.write_polylines(os.path.join(d, "polylines.txt"), nx, ny, slices, comment="real_anatomy input")
    ic.write_text(os.path.join(d, "slice_z.txt"), ",".join("%.6g" % (z * dz) for z in kept) + "\n")


def run_isoloft(d, kind, args, out, threads):
    src = os.path.join(d, "polylines.txt") if kind == "polylines" else os.path.join(d, kind)
    zs = open(os.path.join(d, "slice_z.txt")).read().strip()
    cmd = [ic.isoloft_exe(), "reconstruct", src, "-o", out, "--report", out + ".json", "--quiet",
           "--threads", str(threads)] + args
    if kind != "polylines":
        cmd += ["--input", "masks" if kind == "masks" else "contours", "--slice-z", zs]
    t = time.perf_counter()
    ic.run(cmd)
    wall = time.perf_counter() - t
    rep = ic.read_json(out + ".json")
    return peers.read_mesh(out), rep["timings_s"]["total"], wall


def case_id(c, truth, k):
    return "%s%d_%s_k%d" % (c[0], c[1], truth, k)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "real_anatomy"))
    ap.add_argument("--cases", help="dataset:label list (default all of CASES)")
    ap.add_argument("--ks", default="2,4,8")
    ap.add_argument("--truths", default="staircase,smooth")
    ap.add_argument("--systems", help="only these systems (default all)")
    ap.add_argument("--no-ablation", action="store_true")
    ap.add_argument("--ablation-ks", help="run the ablation variants only at these k (default: every k)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--redo", default="", help="rerun these systems; 'isoloft' = every isoloft row")
    ap.add_argument("--fresh", action="store_true", help="discard OUT/rows.jsonl")
    ap.add_argument("--add", action="append", default=[], help="NAME=COMMAND or NAME=DIR (see usage)")
    ap.add_argument("--keep-meshes", action="store_true")
    a = ap.parse_args()
    import vtk
    vtk.vtkSMPTools.Initialize(a.threads)
    os.makedirs(a.out, exist_ok=True)
    rows_path = os.path.join(a.out, "rows.jsonl")
    if a.fresh and os.path.exists(rows_path):
        os.remove(rows_path)

    cases = CASES
    if a.cases:
        want = {(s.split(":")[0], int(s.split(":")[1])) for s in a.cases.split(",")}
        cases = [c for c in CASES if (c[0], c[1]) in want]
    ks = [int(k) for k in a.ks.split(",")]
    truths = a.truths.split(",")
    systems = {n: ("masks", v) for n, v in ISOLOFT_SYSTEMS.items()}
    if not a.no_ablation:
        systems.update(ABLATION)
    systems.update({p: ("peer", None) for p in PEER_SYSTEMS})
    added = {}
    for s in a.add:
        name, spec = s.split("=", 1)
        added[name] = spec
        systems[name] = ("added", spec)
    if a.systems:
        systems = {n: v for n, v in systems.items() if n in a.systems.split(",")}
    if not peers.mci_available() and "mci" in systems:
        print("real_anatomy: skipping mci: %s has no node_modules (npm ci there; scripts/real_anatomy.sh does)"
              % peers.NODE_DIR, flush=True)
        del systems["mci"]
    redo = set(a.redo.split(",")) - {""}

    done = {}
    if os.path.exists(rows_path):
        for line in open(rows_path):
            r = json.loads(line)
            done[(r["case_id"], r["system"])] = r
    if redo:  # drop the rows to redo so rows.jsonl holds one row per (case, system)
        keep = [r for key, r in done.items()
                if not (r["system"] in redo or ("isoloft" in redo and r.get("kind") == "isoloft"))]
        done = {(r["case_id"], r["system"]): r for r in keep}
        with open(rows_path + ".tmp", "w") as f:
            for r in keep:
                f.write(json.dumps(r) + "\n")
        os.replace(rows_path + ".tmp", rows_path)

    t_start = time.perf_counter()
    vols = {}
    with open(rows_path, "a") as rows:
        for c in cases:
            dataset, label, name, _ = c
            if dataset not in vols:
                if dataset == "aal" and not os.path.exists(AAL):
                    print("real_anatomy: skipping AAL: %s missing (apt-get install mricron-data)" % AAL)
                    vols[dataset] = None
                else:
                    vols[dataset] = load_volume(dataset)
            if vols[dataset] is None:
                continue
            vol, dz = vols[dataset]
            for truth in truths:
                sigma = TRUTH_SIGMA_MM[truth]
                mask, z0 = crop(vol == label, CROP_PAD, int(np.ceil(3 * sigma / dz)) + 1)
                tr = am.Truth.smoothed(mask, dz, sigma)
                inp = mask if truth == "staircase" else tr.field > am.TRUTH_LEVEL
                for k in ks:
                    cid = case_id(c, truth, k)
                    todo = [s for s in systems if (cid, s) not in done and not (
                        s in ABLATION and a.ablation_ks and str(k) not in a.ablation_ks.split(","))]
                    if not todo:
                        continue
                    # Input slices: global index a multiple of k; first to last non-empty.
                    on_grid = [z for z in range(inp.shape[0]) if (z + z0) % k == 0]
                    ne = [z for z in on_grid if inp[z].any()]
                    if len(ne) < 2:  # one input slice: no slice range to score
                        print("%-28s skipped: %d input slice(s) hold the structure" % (cid, len(ne)), flush=True)
                        continue
                    kept = [z for z in on_grid if ne[0] <= z <= ne[-1]]
                    leftout = [z for z in range(ne[0] + 1, ne[-1]) if z not in set(kept)]
                    d = os.path.join(a.out, "inputs", cid)
                    write_inputs(d, inp, kept, dz)
                    geo = dict(z_lo=ne[0] * dz, z_hi=ne[-1] * dz, planes=[z * dz for z in kept], spacing=k * dz,
                               leftout=leftout, inputs={z: inp[z] for z in kept})
                    mdir = os.path.join(a.out, "meshes")
                    os.makedirs(mdir, exist_ok=True)
                    for s in todo:
                        kind, spec = systems[s]
                        out = os.path.join(mdir, "%s_%s.ply" % (cid, s))
                        row = {"case_id": cid, "dataset": dataset, "label": label, "structure": name, "truth": truth,
                               "k": k, "system": s, "kind": "isoloft" if kind in ("masks", "contours", "polylines")
                               else kind, "group": "ablation" if s in ABLATION else "system",
                               "input_slices": len(kept), "crop_zyx": list(mask.shape)}
                        try:
                            if kind == "peer":
                                poly, secs = peers.timed(s, inp, kept)
                                poly, wall = am.scale_z(poly, dz), secs
                                if a.keep_meshes:
                                    peers.write_ply(poly, out)
                            elif kind == "added":
                                if os.path.isdir(spec):
                                    poly, secs, wall = peers.read_mesh(os.path.join(spec, cid + ".ply")), np.nan, np.nan
                                else:
                                    cmd = spec.format(masks_dir=os.path.join(d, "masks"),
                                                      contours_dir=os.path.join(d, "contours"),
                                                      polylines=os.path.join(d, "polylines.txt"),
                                                      slice_z=open(os.path.join(d, "slice_z.txt")).read().strip(),
                                                      out=out)
                                    t = time.perf_counter()
                                    subprocess.run(cmd, shell=True, check=True)
                                    secs = wall = time.perf_counter() - t
                                    poly = peers.read_mesh(out)
                            else:
                                diag = float(np.hypot(*vol.shape[1:]))
                                args = [x.format(paper_tol_10="%.4g" % (10 * PAPER_TOL_UNIT * diag)) for x in spec]
                                poly, secs, wall = run_isoloft(d, kind, args, out, a.threads)
                                if not a.keep_meshes:
                                    os.remove(out)
                                os.remove(out + ".json")
                            row["seconds"], row["wall_s"] = secs, wall
                            t = time.perf_counter()
                            row.update(am.evaluate(poly, tr, **geo))
                            row["eval_s"] = time.perf_counter() - t
                        except Exception as e:  # a failed system is a row with its error, not a crash
                            row["error"] = "%s: %s" % (type(e).__name__, str(e)[-300:])
                        rows.write(json.dumps(row) + "\n")
                        rows.flush()
                        print("%-28s %-24s %s" % (cid, s, row.get("error") or "mean %.3f mm, %.2f s" % (
                            row["mean"], row["seconds"])), flush=True)
    ic.write_json(os.path.join(a.out, "run.json"), {"seconds": time.perf_counter() - t_start,
                                                      "threads": a.threads, "cases": [list(c) for c in cases],
                                                      "ks": ks, "truths": truths, "systems": list(systems),
                                                      "vtk": vtk.vtkVersion.GetVTKVersion()})


if __name__ == "__main__":
    main()
