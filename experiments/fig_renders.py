#!/usr/bin/env python3
"""Paper Fig. 6 and Figs. 10-13 analogues: renders of reconstructions.

Questions:
  Fig. 6   what does the distance-dependent filter (paper 2.3) remove? Each
           dataset is reconstructed with and without it (and with levin);
           creases are counted as the share of mesh edges whose dihedral angle
           exceeds CREASE_DEG, and on the analytic set J the mean normal angle
           to the true surface is measured by `isoloft eval`.
  Figs 10-13  each dataset's reconstruction, with and without its input
           contours drawn (meshes kept by reproduce_tables.py).

usage: fig_renders.py --data DIR --out DIR   (after reproduce_tables.py)
"""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402

# An edge of a smooth surface sampled at about one triangle per pixel turns by
# a few degrees; Marching Cubes through a crease (a kink in the interpolated
# field) turns by far more. 30 degrees separates the two on the analytic set.
CREASE_DEG = 30.0
FIGS = {"P": 10, "J": 11, "T0": 12, "T1": 13}
VIEW = {"P": (30, 20), "J": (35, 20), "T0": (35, 30), "T1": (35, 30)}  # azimuth, elevation (deg)


def crease_share(ply):
    """Share of interior edges whose dihedral angle exceeds CREASE_DEG."""
    v, f, _ = ic.read_ply(ply)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    face = np.tile(np.arange(len(f)), 3)
    key = np.minimum(e[:, 0], e[:, 1]) * (len(v) + 1) + np.maximum(e[:, 0], e[:, 1])
    order = np.argsort(key, kind="stable")
    key, face = key[order], face[order]
    pair = np.nonzero(key[1:] == key[:-1])[0]
    cosang = np.einsum("ij,ij->i", n[face[pair]], n[face[pair + 1]])
    sharp = np.count_nonzero(cosang < np.cos(np.radians(CREASE_DEG)))
    return sharp / max(len(pair), 1), len(pair)


def render(out_png, meshes, view, contours=None, size=700, colour=None):
    args = [ic.experiment_exe("render_mesh"), out_png, *meshes, "--size", size, size, "--azim", view[0], "--elev", view[1]]
    if contours:
        args += ["--contours", contours]
    if colour:
        args += ["--color", colour]
    ic.run(args)


def panels(out_png, images, titles, suptitle):
    fig, axs = plt.subplots(1, len(images), figsize=(4.2 * len(images), 4.6))
    for ax, im, t in zip(np.atleast_1d(axs), images, titles):
        ax.imshow(plt.imread(im))
        ax.set_title(t, fontsize=9)
        ax.axis("off")
    fig.suptitle(suptitle, fontsize=11)
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    plt.close(fig)


def scaled_contours(ds, data_dir, scratch, scale):
    """The dataset's contour CSV in the mesh's units (meshes carry the pixel size)."""
    src = os.path.join(data_dir, ds["contours_csv"])
    if scale == 1.0:
        return src
    dst = os.path.join(scratch, ds["name"] + "_contours_scaled.csv")
    lines = []
    for l in open(src):
        l = l.strip()
        lines.append(",".join("%.4f" % (float(x) * scale) for x in l.split(",")) if l else "")
    ic.write_text(dst, "\n".join(lines) + "\n")
    return dst


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.path.join(ic.ROOT, "experiments", "out", "reproduce", "data"))
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "reproduce"))
    a = ap.parse_args()
    scratch = os.path.join(a.out, "scratch")
    renders = os.path.join(a.out, "renders")
    os.makedirs(renders, exist_ok=True)
    tables = ic.read_json(os.path.join(a.out, "tables.json"))

    # Figs. 10-13: each dataset, with and without its contours.
    for name, num in FIGS.items():
        ds = tables["datasets"][name]["dataset"]
        ddir = os.path.join(a.data, name)
        reports = tables["datasets"][name]["methods"]["marker2006"]["reports"]
        meshes = tables["datasets"][name]["methods"]["marker2006"]["meshes"]  # label runs: the coloured combined mesh
        scale = reports[0]["input"]["pixel_size"]
        plain = os.path.join(renders, "%s_mesh.png" % name)
        withc = os.path.join(renders, "%s_mesh_contours.png" % name)
        render(plain, meshes, VIEW[name])
        render(withc, meshes, VIEW[name], contours=scaled_contours(ds, ddir, scratch, scale))
        tri = tables["datasets"][name]["methods"]["marker2006"]["triangles"]
        panels(os.path.join(a.out, "fig%d_%s.png" % (num, name)), [plain, withc],
               ["reconstruction (%d triangles)" % tri, "with the %d input slices' contours" % ds["slices"]],
               "Fig. %d analogue: %s (stand-in for the paper's %s)" % (num, name, ds["paper_name"]))
        print("fig %d: %s" % (num, name), flush=True)

    # Fig. 6: with and without the filter (undecimated Marching Cubes meshes).
    fig6 = {"crease_deg": CREASE_DEG, "datasets": {}}
    for name in FIGS:
        ds = tables["datasets"][name]["dataset"]
        ddir = os.path.join(a.data, name)
        row = {}
        for variant, extra in (("filter", []), ("no-filter", ["--no-filter"]), ("levin", ["--method", "levin"])):
            share_sum, edges_sum, files = 0.0, 0, []
            for i, r in enumerate(ds["runs"]):
                ply = os.path.join(scratch, "fig6_%s_%s_%d.ply" % (name, variant, i))
                inputs = [os.path.join(ddir, p) for p in r["inputs"]]
                method = extra[extra.index("--method") + 1] if "--method" in extra else None
                ic.isoloft("reconstruct", *inputs, *ic.method_args(r["args"], method), *extra, "-o", ply, "--quiet")
                s, ne = crease_share(ply)
                share_sum += s * ne
                edges_sum += ne
                files.append(ply)
            row[variant] = {"crease_edge_share": share_sum / max(edges_sum, 1), "edges": edges_sum, "files": files}
            if ds.get("truth"):
                ev = os.path.join(scratch, "fig6_%s_%s_eval.json" % (name, variant))
                ic.isoloft("eval", "--mesh", files[0], "--truth", os.path.join(ddir, ds["truth"]), "--report", ev)
                e = ic.read_json(ev)
                row[variant]["mean_normal_angle_deg"] = e["two_sided"]["in_range"]["mean_normal_angle_deg"]
                ts = e["two_sided"]["in_range"]  # mean two-sided = average of both directions, as in accuracy.cpp
                row[variant]["mean_distance_px"] = 0.5 * (ts["mesh_to_truth"]["mean_px"] + ts["truth_to_mesh"]["mean_px"])
        fig6["datasets"][name] = row
        print("fig 6: %s creases filter %.4f / no-filter %.4f / levin %.4f" % (
            name, row["filter"]["crease_edge_share"], row["no-filter"]["crease_edge_share"], row["levin"]["crease_edge_share"]),
            flush=True)
    # Renders for Fig. 6: the dataset where the filter removes the largest
    # share of the creases.
    def removed(n):
        r = fig6["datasets"][n]
        return 1 - r["filter"]["crease_edge_share"] / max(r["no-filter"]["crease_edge_share"], 1e-12)
    best = max(fig6["datasets"], key=removed)
    fig6["shown"] = best
    imgs, titles = [], []
    for variant in ("no-filter", "filter", "levin"):
        r = fig6["datasets"][best][variant]
        png = os.path.join(renders, "fig6_%s_%s.png" % (best, variant))
        render(png, r["files"], VIEW[best])
        imgs.append(png)
        t = "%s: creases %.2f%% of edges" % ("marker2006 " + variant if variant != "levin" else "levin", 100 * r["crease_edge_share"])
        if "mean_normal_angle_deg" in r:
            t += ", normal err %.1f deg" % r["mean_normal_angle_deg"]
        titles.append(t)
    panels(os.path.join(a.out, "fig6_filter.png"), imgs, titles,
           "Fig. 6 analogue: %s without and with the distance filter, and levin (dihedral > %g deg = crease)" % (best, CREASE_DEG))
    ic.write_json(os.path.join(a.out, "fig6_filter.json"), fig6)


if __name__ == "__main__":
    main()
