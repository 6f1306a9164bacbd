#!/usr/bin/python3
"""Paper Fig. 9 analogue: the overshoot "lip" of an unconstrained z spline
and its absence with the monotone spline.

A stack of concentric circles whose radius steps abruptly (R_BIG for the
first slices, R_SMALL for the rest; 8:1 slice spacing) is reconstructed with
marker2006 and the Catmull-Rom, natural and monotone splines, and with the
Levin baseline (monotone spline). Every pixel inside the big disc and
outside the small one sees a step in its signed distance; a spline without
the monotonicity constraint overshoots it between the last two big slices, so
the surface bulges beyond the big contour there (the lip).

Measured from each PLY: for vertices with z strictly between two input
slices, radial distance from the circles' axis minus the larger of the two
neighbouring contour radii (px); max and 99th percentile over the interior
intervals (the step lip; the headline numbers), over all intervals, and per
interval. The first and last intervals are reported apart: there the z
spline also runs through the end-cap virtual slices (README, End caps),
whose steep drop makes unconstrained splines bulge beyond the end contours
too.

usage: /usr/bin/python3 experiments/fig_lip.py --out DIR [--azim A --elev E]
writes DIR/fig9_lip.png, DIR/fig9_lip.json, and the stack, meshes and renders under DIR/fig9_lip/
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SIZE = 200
CX = CY = 100.0
SPACING = 8.0
R_BIG, R_SMALL = 60.0, 25.0
N_BIG, N_SMALL = 4, 4  # the step is away from the end slices
N_POINTS = 720  # polygon vertices per circle

RUNS = [  # key, title, extra CLI args
    ("catmull-rom", "marker2006, Catmull-Rom", ["--spline", "catmull-rom"]),
    ("natural", "marker2006, natural cubic", ["--spline", "natural"]),
    ("monotone", "marker2006, monotone (default)", ["--spline", "monotone"]),
    ("levin", "Levin baseline, monotone", ["--method", "levin"]),
    ("levin-catmull-rom", "Levin baseline, Catmull-Rom", ["--method", "levin", "--spline", "catmull-rom"]),
]
FIGURE_RUNS = ["catmull-rom", "monotone", "levin", "natural"]


def circle(r):
    t = np.linspace(0, 2 * np.pi, N_POINTS, endpoint=False)
    return np.stack([CX + r * np.cos(t), CY + r * np.sin(t)], axis=1)


def stack():
    radii = [R_BIG] * N_BIG + [R_SMALL] * N_SMALL
    zs = [k * SPACING for k in range(len(radii))]
    return zs, radii


def stats(ex):
    return {"max_px": float(ex.max()), "p99_px": float(np.percentile(ex, 99)), "vertices": int(ex.size)}


def measure(verts, zs, radii):
    rho = np.hypot(verts[:, 0] - CX, verts[:, 1] - CY)
    z = verts[:, 2]
    eps = 1e-4
    all_ex = []
    per = []
    for k in range(len(zs) - 1):
        sel = (z > zs[k] + eps) & (z < zs[k + 1] - eps)
        ex = rho[sel] - max(radii[k], radii[k + 1])
        all_ex.append(ex)
        per.append({"interval": [zs[k], zs[k + 1]], "radii": [radii[k], radii[k + 1]], "vertices": int(sel.sum()),
                    "max_px": float(ex.max()) if ex.size else None,
                    "p99_px": float(np.percentile(ex, 99)) if ex.size else None,
                    "z_of_max": float(z[sel][np.argmax(ex)]) if ex.size else None})
    # Baseline: the same excess on the slice planes themselves (contour
    # fidelity, e.g. the Levin baseline's raster quantization), not a lip.
    on = np.zeros(len(z), bool)
    at = np.zeros(len(z))
    for zk, rk in zip(zs, radii):
        m = np.abs(z - zk) <= eps
        on |= m
        at[m] = rk
    interior = stats(np.concatenate(all_ex[1:-1]))
    return {**interior, "at_slices": stats(rho[on] - at[on]), "interior_intervals": interior, "end_intervals": stats(np.concatenate([all_ex[0], all_ex[-1]])),
            "all_intervals": stats(np.concatenate(all_ex)), "per_interval": per}


def crop(img, pad=8):
    """Trims the uniform background border of a render."""
    m = np.any(np.abs(img[..., :3] - img[0, 0, :3]) > 1e-3, axis=2)
    r, c = np.where(m.any(1))[0], np.where(m.any(0))[0]
    if not r.size:
        return img
    return img[max(r[0] - pad, 0):r[-1] + pad + 1, max(c[0] - pad, 0):c[-1] + pad + 1]


def px(v):
    return ("%.2f" % v).replace("-0.00", "0.00")


def profile(verts, zs):
    """Max radial distance per z bin (1 px) over the stack's z range."""
    rho = np.hypot(verts[:, 0] - CX, verts[:, 1] - CY)
    edges = np.arange(zs[0] - SPACING / 2, zs[-1] + SPACING / 2 + 1e-9, 1.0)
    idx = np.digitize(verts[:, 2], edges) - 1
    out = np.full(len(edges) - 1, np.nan)
    for b in range(len(edges) - 1):
        m = idx == b
        if m.any():
            out[b] = rho[m].max()
    return 0.5 * (edges[:-1] + edges[1:]), out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--azim", type=float, default=0.0)
    ap.add_argument("--elev", type=float, default=8.0)
    a = ap.parse_args()
    work = os.path.join(a.out, "fig9_lip")
    os.makedirs(work, exist_ok=True)

    zs, radii = stack()
    stack_txt = os.path.join(work, "step_circles.txt")
    ic.write_polylines(stack_txt, SIZE, SIZE, [(z, [circle(r)]) for z, r in zip(zs, radii)],
                       comment="fig_lip.py: concentric circles, radius %g for %d slices then %g for %d, spacing %g"
                               % (R_BIG, N_BIG, R_SMALL, N_SMALL, SPACING))
    contours_csv = os.path.join(work, "contours.csv")
    ic.write_contours_csv(contours_csv, [np.column_stack([circle(r), np.full(N_POINTS, z)]) for z, r in zip(zs, radii)])

    result = {"stack": {"size": [SIZE, SIZE], "centre": [CX, CY], "z": zs, "radii": radii, "spacing_px": SPACING},
              "overshoot_definition": "vertices with z strictly between two input slices: radial distance from the "
                                      "axis minus the larger of the two neighbouring contour radii (px); max_px/p99_px "
                                      "are over the interior intervals (the lip at the step); end_intervals are the "
                                      "first and last interval, where the spline also runs through the end-cap "
                                      "virtual slices",
              "view": {"azim": a.azim, "elev": a.elev, "size": [600, 600]},
              "runs": {}}
    profiles = {}
    for key, title, args in RUNS:
        ply = os.path.join(work, key + ".ply")
        ic.isoloft("reconstruct", stack_txt, "-o", ply, "-q", *args)
        verts, faces, _ = ic.read_ply(ply)
        m = measure(verts, zs, radii)
        m.update({"title": title, "args": args, "triangles": int(len(faces))})
        result["runs"][key] = m
        profiles[key] = profile(verts, zs)
        if key in FIGURE_RUNS:
            ic.run([ic.experiment_exe("render_mesh"), os.path.join(work, key + ".png"), ply, "--size", 600, 600,
                    "--azim", a.azim, "--elev", a.elev, "--contours", contours_csv])
        print("%-18s lip (interior) max %6.2f px  p99 %6.2f px   end intervals max %6.2f px  p99 %6.2f px   "
              "on slices max %5.2f px" % (key, m["max_px"], m["p99_px"], m["end_intervals"]["max_px"],
                                          m["end_intervals"]["p99_px"], m["at_slices"]["max_px"]))

    fig = plt.figure(figsize=(15, 9.5), dpi=120)
    gs = fig.add_gridspec(2, 3, width_ratios=[1, 1, 1.15])
    for i, key in enumerate(FIGURE_RUNS):
        ax = fig.add_subplot(gs[i // 2, i % 2])
        ax.imshow(crop(plt.imread(os.path.join(work, key + ".png"))))
        r = result["runs"][key]
        e = r["end_intervals"]
        ax.set_title("%s\nlip at the step: max %s px, p99 %s px\n(end intervals: max %s, p99 %s; on the slices: max %s px)"
                     % (r["title"], px(r["max_px"]), px(r["p99_px"]), px(e["max_px"]), px(e["p99_px"]),
                        px(r["at_slices"]["max_px"])), fontsize=9)
        ax.set_axis_off()
    ax = fig.add_subplot(gs[:, 2])
    styles = {"catmull-rom": dict(color="tab:red", ls="--"), "natural": dict(color="tab:orange", ls=":"),
              "monotone": dict(color="tab:blue", lw=2), "levin": dict(color="tab:green", ls="-."),
              "levin-catmull-rom": dict(color="tab:purple", ls=(0, (1, 1)))}
    for key, _, _ in RUNS:
        zc, rmax = profiles[key]
        ax.plot(rmax, zc, label=result["runs"][key]["title"], **styles[key])
    ax.plot(radii, zs, "ks", ms=6, label="input contours")
    ax.set_xlabel("max radial distance of mesh vertices (px)")
    ax.set_ylabel("z (px)")
    ax.set_title("silhouette radius per 1 px of z", fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(alpha=0.3)
    fig.suptitle("Fig. 9: radius steps %g -> %g px between slices (spacing %g px); lip = bulge beyond the larger "
                 "neighbouring contour. Side view azim %g, elev %g; dark lines = input contours"
                 % (R_BIG, R_SMALL, SPACING, a.azim, a.elev), fontsize=10)
    fig.tight_layout()
    png = os.path.join(a.out, "fig9_lip.png")
    fig.savefig(png)
    ic.write_json(os.path.join(a.out, "fig9_lip.json"), result)
    print("wrote", png)


if __name__ == "__main__":
    main()
