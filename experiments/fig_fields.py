#!/usr/bin/env python3
"""Paper Figs. 3-5 analogues from the program's own intermediate fields.

Question: what do the stages of paper 2.1-2.3 do to one slice? Runs
`isoloft reconstruct --dump-stages` on a dataset and plots, for one slice:
  Fig. 3  a close-up of the binary contour pixels with the MPU curve (zero set);
  Fig. 4  the MPU field and the extended Euclidean distance field;
  Fig. 5  the filtered field and the difference image (filtered - unfiltered),
          with the |d| = d_min band drawn: the filter only acts away from the curve.
It also measures what Fig. 5 claims (no change within d_min, no sign change).

usage: fig_fields.py --dataset DIR --out DIR [--slice K] [--label L] [--tag NAME]
"""
import argparse
import glob
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402


def zero_contour(ax, field, x0, y0, **kw):
    h, w = field.shape
    xs, ys = np.arange(w) + x0, np.arange(h) + y0
    return ax.contour(xs, ys, field, levels=[0.0], **kw)


def show(ax, field, x0, y0, cmap, vmin, vmax, title):
    h, w = field.shape
    im = ax.imshow(field, cmap=cmap, vmin=vmin, vmax=vmax, origin="upper",
                   extent=(x0 - 0.5, x0 + w - 0.5, y0 + h - 0.5, y0 - 0.5), interpolation="nearest")
    ax.set_title(title, fontsize=10)
    ax.set_xticks([])
    ax.set_yticks([])
    return im


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dataset", required=True, help="dataset dir with dataset.json (reproduce_data.py)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--slice", type=int, default=-1, help="slice index (default: the middle slice)")
    ap.add_argument("--label", type=int, default=0)
    ap.add_argument("--tag", default="")
    a = ap.parse_args()
    ds = ic.read_json(os.path.join(a.dataset, "dataset.json"))
    run = ds["runs"][0]
    inputs = [os.path.join(a.dataset, p) for p in run["inputs"]]
    stages = os.path.join(a.out, "scratch", "stages_" + ds["name"])
    for f in glob.glob(os.path.join(stages, "*")):
        os.remove(f)
    os.makedirs(stages, exist_ok=True)
    extra = ["--labels", str(a.label)] if a.label else []
    ic.isoloft("reconstruct", *inputs, *run["args"], *extra, "-o", os.path.join(a.out, "scratch", "fields.ply"),
               "--dump-stages", stages, "--quiet")
    k = a.slice if a.slice >= 0 else ds["slices"] // 2
    base = os.path.join(stages, "label%d_slice%03d_" % (a.label, k))
    mpu, hdr = ic.read_nrrd(base + "mpu.nrrd")
    dist, _ = ic.read_nrrd(base + "distance.nrrd")
    filt, _ = ic.read_nrrd(base + "filtered.nrrd")
    diff = filt - dist
    x0, y0 = ic.nrrd_origin(hdr)[:2]
    pts = np.loadtxt(base + "points.csv", delimiter=",", skiprows=1, ndmin=2)
    d_min = 4.0  # paper 2.3 default, also isoloft's (filter.d_min)
    tag = a.tag or ds["name"]

    # Fig. 3: close-up of the input contour pixels (the binary image when the
    # input is contour images; the contour points otherwise) with the MPU curve.
    fig, ax = plt.subplots(figsize=(5.2, 5.2))
    c = pts[np.argmax(pts[:, 0] - pts[:, 1])]  # a point on a diagonal flank: staircase pixels
    half = 14
    win = (c[0] - half, c[0] + half, c[1] - half, c[1] + half)
    img_path = inputs[0] if not os.path.isdir(inputs[0]) else sorted(glob.glob(os.path.join(inputs[0], "*.png")))[k]
    if img_path.endswith(".png"):
        img = plt.imread(img_path)
        if img.ndim == 3:
            img = img[..., 0]
        ax.imshow(img > 0.5, cmap="gray_r", vmin=0, vmax=2.5, origin="upper", interpolation="nearest",
                  extent=(-0.5, img.shape[1] - 0.5, img.shape[0] - 0.5, -0.5))
    sel = (pts[:, 0] > win[0] - 2) & (pts[:, 0] < win[1] + 2) & (pts[:, 1] > win[2] - 2) & (pts[:, 1] < win[3] + 2)
    ax.plot(pts[sel, 0], pts[sel, 1], ".", color="tab:blue", ms=4, label="contour points (pixel centres)")
    ax.quiver(pts[sel, 0], pts[sel, 1], pts[sel, 2], -pts[sel, 3], color="tab:blue", scale=25, width=0.004,
              label="outward normals")
    zero_contour(ax, mpu, x0, y0, colors="tab:red", linewidths=2)
    ax.plot([], [], color="tab:red", lw=2, label="MPU curve f = 0")
    ax.set_xlim(win[0], win[1])
    ax.set_ylim(win[3], win[2])
    ax.set_aspect("equal")
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title("Fig. 3: contour pixels and MPU curve (%s, slice %d)" % (tag, k), fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "fig3_mpu_closeup.png"), dpi=110)
    plt.close(fig)

    # Fig. 4: MPU field and extended distance field.
    fig, axs = plt.subplots(1, 2, figsize=(10, 5))
    lim = float(np.percentile(np.abs(mpu), 99))
    im = show(axs[0], mpu, x0, y0, "RdBu", -lim, lim, "MPU field f (positive inside)")
    zero_contour(axs[0], mpu, x0, y0, colors="k", linewidths=1)
    fig.colorbar(im, ax=axs[0], shrink=0.8)
    lim = float(np.abs(dist).max())
    im = show(axs[1], dist, x0, y0, "RdBu", -lim, lim, "signed distance (band + extension), px")
    h, w = dist.shape
    axs[1].contour(np.arange(w) + x0, np.arange(h) + y0, dist, levels=np.arange(-lim, lim, 10.0), colors="k",
                   linewidths=0.4)
    fig.colorbar(im, ax=axs[1], shrink=0.8)
    fig.suptitle("Fig. 4: %s slice %d" % (tag, k))
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "fig4_fields.png"), dpi=100)
    plt.close(fig)

    # Fig. 5: filtered field and the difference image.
    fig, axs = plt.subplots(1, 2, figsize=(10, 5))
    im = show(axs[0], filt, x0, y0, "RdBu", -lim, lim, "filtered distance, px")
    axs[0].contour(np.arange(w) + x0, np.arange(h) + y0, filt, levels=np.arange(-lim, lim, 10.0), colors="k",
                   linewidths=0.4)
    fig.colorbar(im, ax=axs[0], shrink=0.8)
    dl = max(float(np.abs(diff).max()), 1e-6)
    im = show(axs[1], diff, x0, y0, "PuOr", -dl, dl, "filtered - unfiltered, px")
    axs[1].contour(np.arange(w) + x0, np.arange(h) + y0, dist, levels=[-d_min, d_min], colors="0.4",
                   linewidths=0.8, linestyles="--")
    zero_contour(axs[1], dist, x0, y0, colors="k", linewidths=1)
    fig.colorbar(im, ax=axs[1], shrink=0.8)
    fig.suptitle("Fig. 5: %s slice %d (dashed: |d| = d_min = %g px; black: the curve)" % (tag, k, d_min))
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "fig5_filter.png"), dpi=100)
    plt.close(fig)

    near = np.abs(dist) <= d_min
    stats = {"dataset": ds["name"], "slice": k, "label": a.label,
             "max_abs_change_px": float(np.abs(diff).max()),
             "max_abs_change_within_d_min_px": float(np.abs(diff[near]).max()) if near.any() else 0.0,
             "changed_pixels": int(np.count_nonzero(diff)), "pixels": int(diff.size),
             "sign_changes": int(np.count_nonzero(np.sign(filt) != np.sign(dist))),
             "contour_points": int(len(pts))}
    ic.write_json(os.path.join(a.out, "fig5_filter.json"), stats)
    print("figs 3-5: %s slice %d, filter max change %.2f px, within d_min %.3g px, sign changes %d"
          % (tag, k, stats["max_abs_change_px"], stats["max_abs_change_within_d_min_px"], stats["sign_changes"]))


if __name__ == "__main__":
    main()
