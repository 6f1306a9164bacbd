#!/usr/bin/python3
"""Paper Fig. 8 analogue: a spline through five data values with and without
the monotonicity constraint.

The library's own z splines (lib/isoloft/interp/spline.h) are evaluated by
build/experiments/spline_curves through a monotone, step-like sequence; the
overshoot of each kind is measured per interval as the largest excursion
beyond [min, max] of the interval's two data values.

usage: /usr/bin/python3 experiments/fig_spline.py --out DIR
writes DIR/fig8_spline.png, DIR/fig8_spline.json (and the curve CSVs)
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

Z = [0, 1, 2, 3, 4]
# A monotone step: flat, one rise, flat (what one pixel between a big and a
# small contour sees along z in fig_lip.py, scaled to [0, 1]).
V = [0, 0, 1, 1, 1]
KINDS = [  # csv column, label, style
    ("catmull_rom", "Catmull-Rom (no constraint)", dict(color="tab:red", ls="--")),
    ("natural", "natural cubic (no constraint)", dict(color="tab:orange", ls=":")),
    ("linear", "linear", dict(color="0.6", ls="-", lw=0.8)),
    ("monotone", "monotone (Hyman 1983)", dict(color="tab:blue", ls="-", lw=2)),
]


def overshoot(z, f, zk, vk):
    """Per interval: largest excursion of f beyond [min, max] of its two data values."""
    per = []
    for i in range(len(zk) - 1):
        sel = (z >= zk[i]) & (z <= zk[i + 1])
        lo, hi = min(vk[i], vk[i + 1]), max(vk[i], vk[i + 1])
        ex = np.maximum(np.maximum(f[sel] - hi, lo - f[sel]), 0.0)
        j = int(np.argmax(ex))
        per.append({"interval": [zk[i], zk[i + 1]], "overshoot": float(ex[j]), "at_z": float(z[sel][j])})
    return per


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--samples", type=int, default=2001)
    ap.add_argument("--v", default=",".join(map(str, V)), help="five data values at z = 0..4")
    a = ap.parse_args()
    vals = [float(x) for x in a.v.split(",")]
    if len(vals) != len(Z):
        ap.error("--v needs %d values" % len(Z))
    V[:] = vals
    os.makedirs(a.out, exist_ok=True)
    curves = os.path.join(a.out, "fig8_spline_curves.csv")
    points = os.path.join(a.out, "fig8_spline_points.csv")
    ic.run([ic.experiment_exe("spline_curves"), "--z", ",".join(map(str, Z)), "--v", ",".join(map(str, V)),
            "--samples", a.samples, "--out", curves, "--points", points])
    d = np.genfromtxt(curves, delimiter=",", names=True)
    p = np.genfromtxt(points, delimiter=",", names=True)
    z = d["z"]

    result = {"z": Z, "v": V, "samples": a.samples,
              "overshoot_definition": "per interval, max excursion of the spline beyond [min, max] of the "
                                      "interval's two data values; 'max' is the largest over all intervals",
              "kinds": {}}
    for col, _, _ in KINDS:
        per = overshoot(z, d[col], Z, V)
        worst = max(per, key=lambda r: r["overshoot"])
        result["kinds"][col] = {"max_overshoot": worst["overshoot"], "worst_interval": worst["interval"],
                                "per_interval": per, "min_value": float(d[col].min()),
                                "max_value": float(d[col].max())}

    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=150)
    ax.axhspan(min(V), max(V), color="0.93", zorder=0)
    for col, label, style in KINDS:
        ov = result["kinds"][col]["max_overshoot"]
        ax.plot(z, d[col], label="%s, overshoot %.3f" % (label, ov), **style)
    ax.plot(p["z"], p["v"], "ko", ms=6, zorder=5, label="data")
    ax.set_xlabel("z (slice)")
    ax.set_ylabel("value (e.g. signed distance of one pixel)")
    ax.set_title("Fig. 8: spline through 5 values, with and without monotonicity")
    ax.legend(fontsize=7.5, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    png = os.path.join(a.out, "fig8_spline.png")
    fig.savefig(png)
    ic.write_json(os.path.join(a.out, "fig8_spline.json"), result)
    for col, _, _ in KINDS:
        print("%-12s max overshoot %.4f in %s" % (col, result["kinds"][col]["max_overshoot"],
                                                   result["kinds"][col]["worst_interval"]))
    print("wrote", png)


if __name__ == "__main__":
    main()
