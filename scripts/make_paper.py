#!/usr/bin/env python3
"""Builds paper/README.md (the reproduction report) from the experiments'
outputs in experiments/out/reproduce/ (scripts/reproduce.sh runs everything).
Copies the tables (Markdown + CSV) and figures into paper/; writes nothing
that was not measured by an experiment.

usage: make_paper.py --out experiments/out/reproduce [--seconds S]
"""
import argparse
import os
import platform
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "experiments"))
import isoloft_common as ic  # noqa: E402

PAPER = os.path.join(ic.ROOT, "paper")
FIGURES = ["fig3_mpu_closeup", "fig4_fields", "fig5_filter", "fig6_filter", "fig8_spline", "fig9_lip",
           "fig10_P", "fig11_J", "fig12_T0", "fig13_T1"]


def field(path, key, sep):
    """The value after `sep` on the first line of `path` starting with `key`, or ""."""
    try:
        for l in open(path):
            if l.startswith(key):
                return l.split(sep, 1)[1].strip().strip('"')
    except OSError:
        pass
    return ""


def machine():
    cpu = field("/proc/cpuinfo", "model name", ":") or "unknown CPU"
    kib = field("/proc/meminfo", "MemTotal", ":").split()
    mem = "%.0f GB RAM" % (int(kib[0]) / 1024 / 1024) if kib else ""
    osname = field("/etc/os-release", "PRETTY_NAME", "=") or platform.platform()
    return "%s, %d cores, %s, %s" % (cpu, os.cpu_count() or 0, mem, osname)


def git_describe():
    r = subprocess.run(["git", "-C", ic.ROOT, "describe", "--always", "--dirty"], capture_output=True, text=True)
    return r.stdout.strip() or "unknown"


def table(out, name):
    for ext in ("md", "csv"):
        shutil.copyfile(os.path.join(out, "%s.%s" % (name, ext)), os.path.join(PAPER, "%s.%s" % (name, ext)))
    return open(os.path.join(out, name + ".md")).read()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "reproduce"))
    ap.add_argument("--seconds", type=int, default=0, help="wall time of the whole reproduction, for the report")
    a = ap.parse_args()
    os.makedirs(os.path.join(PAPER, "figures"), exist_ok=True)
    os.makedirs(os.path.join(PAPER, "data"), exist_ok=True)
    for f in FIGURES:
        shutil.copyfile(os.path.join(a.out, f + ".png"), os.path.join(PAPER, "figures", f + ".png"))
    for f in ("tables", "fig5_filter", "fig6_filter", "fig8_spline", "fig9_lip"):
        shutil.copyfile(os.path.join(a.out, f + ".json"), os.path.join(PAPER, "data", f + ".json"))
    tables = ic.read_json(os.path.join(a.out, "tables.json"))
    f5 = ic.read_json(os.path.join(a.out, "fig5_filter.json"))
    f6 = ic.read_json(os.path.join(a.out, "fig6_filter.json"))
    f8 = ic.read_json(os.path.join(a.out, "fig8_spline.json"))
    f9 = ic.read_json(os.path.join(a.out, "fig9_lip.json"))
    ds = tables["datasets"]
    threads = ds["J"]["methods"]["marker2006"]["threads"]

    s = []
    s.append("# Reproducing Marker, Braude, Museth, Breen 2006 with isoloft\n")
    s.append("*Contour-Based Surface Reconstruction using Implicit Curve Fitting, and Distance Field Filtering and "
             "Interpolation* (Volume Graphics 2006): the paper's tables and figures, redone on stand-in data.\n")
    s.append("Regenerate everything on this page (tables, figures, this file) with\n\n```\nbash scripts/reproduce.sh\n```\n")
    s.append("Last run: isoloft `%s` on %s, %d threads%s. Timings are medians of %d runs.\n" % (
        git_describe(), machine(), threads,
        "; the experiments took %d s after the build" % a.seconds if a.seconds else "", tables["repeats"]))
    s.append("\n\nThe paper's datasets (Barequet's pelvis and jawbone polylines, the Drexel tumour segmentations) are "
             "not public. Each is replaced by data of the same size and kind: real clinical and biological contours "
             "where they exist, an analytic shape where a known truth is wanted (Table 1 says which).\n")

    s.append("\n## Table 1: datasets\n")
    s.append("Stand-ins and their sizes next to the paper's. *fit grid* is where contours are rasterized and the MPU "
             "curve is fitted; *field grid* is where distances are computed; the output volume is the field grid "
             "times the z planes sampled by the spline (one per pixel of z).\n\n")
    s.append(table(a.out, "table1"))
    for name in ("P", "J", "T0", "T1"):
        d = ds[name]["dataset"]
        s.append("- **%s**: %s\n" % (name, d["source"]))

    s.append("\n## Table 2: MPU and pipeline parameters\n")
    s.append("Each set twice: today's defaults (the same for every set; `mpu.tol` by measurement, see the main README) "
             "and the paper's Table 2 (N_min / tol = P 100/15, J 250/10, T0 300/10, T1 300/10). The paper gives tol "
             "without a unit; it is read as MPU's relative error bound in units of 1e-4 of the fit grid's diagonal "
             "(experiments/reproduce_tables.py `PAPER_TOL_UNIT`): 0.7-1.1 field pixels for every set, the "
             "'subpixel error bounds' of the paper's section 2.1; as pixels, 10-15 px would be far coarser than "
             "the contours' own noise. Table 3 times both.\n\n")
    s.append(table(a.out, "table2"))
    if os.path.exists(os.path.join(a.out, "table2_accuracy.md")):
        s.append("\nJ against its analytic truth with both sets (`experiments/table2_accuracy.py`; mesh-to-truth "
                 "distances between the first and last slice, pixels):\n\n")
        s.append(table(a.out, "table2_accuracy"))

    s.append("\n## Table 3: time per stage (seconds)\n")
    s.append("Median of %d runs per row, %d threads, Release build. MPU includes turning contour pixels into points "
             "and normals; Mesh is Marching Cubes; decimation (bounded quadric, %.2f px error, mesh/decimate.h) is timed "
             "once per dataset in its own column, because it alone costs more than all other stages together. The paper's totals are on "
             "a 2 GHz PowerPC G5; the speed-up compares them with our total including decimation.\n\n" % (
                 tables["repeats"], threads, tables["decimate_error_px"]))
    s.append(table(a.out, "table3"))

    s.append("\n## Figures\n")
    s.append("\n### Fig. 3: binary contour and its MPU curve\n\n![fig3](figures/fig3_mpu_closeup.png)\n\n"
             "A close-up of one contour slice of J (1-pixel binary contour, grey), the contour pixel centres with "
             "their outward normals from the Gaussian-filtered mask gradient (paper 2.1, blue), and the fitted MPU "
             "curve f = 0 (red) running smoothly through the staircase.\n")
    s.append("\n### Fig. 4: MPU field and extended distance field\n\n![fig4](figures/fig4_fields.png)\n\n"
             "Left: the MPU implicit function (positive inside). Right: signed Euclidean distance to its zero set, "
             "exact in a narrow band and extended over the grid by fast marching with Mauch's correctness "
             "criterion (paper 2.2); iso-lines every 10 px.\n")
    s.append("\n### Fig. 5: filtered field and difference image\n\n![fig5](figures/fig5_filter.png)\n\n"
             "The distance-dependent Gaussian filter (paper 2.3, equation 3). The difference image is non-zero only "
             "away from the curve, along the medial axes (the ridge inside each disc and the bisector between the "
             "discs), and along the crop border, where the stencil is clamped to the grid. Measured on this slice: largest change %.2f px, largest change within |d| <= 4 px: %.3g px, "
             "sign changes: %d of %d pixels.\n" % (f5["max_abs_change_px"], f5["max_abs_change_within_d_min_px"],
                                                    f5["sign_changes"], f5["pixels"]))
    rows = []
    for name, r in f6["datasets"].items():
        cells = []
        for v in ("no-filter", "filter", "levin"):
            c = "%.2f%%" % (100 * r[v]["crease_edge_share"])
            if "mean_normal_angle_deg" in r[v]:
                c += " / %.2f deg / %.3f px" % (r[v]["mean_normal_angle_deg"], r[v]["mean_distance_px"])
            cells.append(c)
        rows.append("| %s | %s |" % (name, " | ".join(cells)))
    s.append("\n### Fig. 6: with and without the distance filter\n\n![fig6](figures/fig6_filter.png)\n\n"
             "Share of mesh edges with a dihedral angle above %g deg (creases), undecimated Marching Cubes meshes; "
             "on J also the mean normal angle and mean two-sided distance to the true surface. Rendered: %s.\n\n"
             "| set | marker2006 no filter | marker2006 | levin |\n|---|---|---|---|\n%s\n" % (
                 f6["crease_deg"], f6["shown"], "\n".join(rows)))
    k8 = f8["kinds"]
    s.append("\n### Fig. 8: monotone and unconstrained cubic splines\n\n![fig8](figures/fig8_spline.png)\n\n"
             "The library's own z splines (`experiments/spline_curves.cpp`) through five values %s, the sequence one "
             "pixel sees when a contour steps across it. Overshoot beyond the two neighbouring data values: "
             "Catmull-Rom %.3f, natural cubic %.3f, linear %.3f, monotone (Hyman 1983, the default) %.3f.\n" % (
                 ", ".join("%g" % v for v in f8["v"]), k8["catmull_rom"]["max_overshoot"], k8["natural"]["max_overshoot"],
                 k8["linear"]["max_overshoot"], k8["monotone"]["max_overshoot"]))
    r9 = f9["runs"]
    st = f9["stack"]
    rows9 = "\n".join("| %s | %.2f / %.2f | %.2f | %.2f |" % (
        n, r9[n]["interior_intervals"]["max_px"], r9[n]["interior_intervals"]["p99_px"], r9[n]["end_intervals"]["max_px"],
        r9[n]["at_slices"]["max_px"]) for n in ("monotone", "catmull-rom", "natural", "levin", "levin-catmull-rom") if n in r9)
    s.append("\n### Fig. 9: the overshoot lip\n\n![fig9](figures/fig9_lip.png)\n\n"
             "Concentric circles whose radius steps from %g to %g px between slices %g px apart (polyline input). "
             "Catmull-Rom interpolation of the distance fields overshoots and the surface bulges beyond the larger "
             "neighbouring contour (the lip); the monotone spline does not. Lip = radial excess of mesh vertices "
             "between two slices over the larger of their contour radii (px); the end intervals also run through "
             "the end caps, where the unconstrained splines bulge as well. Rows named levin use the Levin-style "
             "pixel distance fields (their 0.4-0.6 px is pixel quantisation, present on the slices too).\n\n"
             "| z spline | lip max / p99 (px) | end intervals max (px) | on the slices max (px) |\n|---|---|---|---|\n%s\n" % (
                 max(st["radii"]), min(st["radii"]), st["spacing_px"], rows9))
    for num, name in ((10, "P"), (11, "J"), (12, "T0"), (13, "T1")):
        d = ds[name]["dataset"]
        m = ds[name]["methods"]["marker2006"]
        s.append("\n### Fig. %d: %s (stand-in for the paper's %s)\n\n![fig%d](figures/fig%d_%s.png)\n\n"
                 "%d slices, %s. Left: the reconstruction (marker2006, decimated, %d triangles, %s). Right: the same "
                 "with its input contours drawn.\n" % (
                     num, name, d["paper_name"], num, num, name, d["slices"], d["kind"], m["triangles"],
                     "every mesh closed and manifold" if m["closed_manifold"] else "NOT all meshes closed and manifold"))

    s.append("\n## Accuracy on analytic shapes\n\nFrom the validation work (`scripts/accuracy.sh`, "
             "[accuracy.md](accuracy.md)):\n\n")
    acc = open(os.path.join(PAPER, "accuracy.md")).read().split("\n", 2)[2]
    s.append(acc)
    # One block per append; a blank line between blocks (Markdown paragraphs).
    ic.write_text(os.path.join(PAPER, "README.md"), "\n".join(b.strip("\n") + "\n" for b in s))
    print("make_paper: wrote paper/README.md")


if __name__ == "__main__":
    main()
