#!/usr/bin/python3
"""Question: do the paper's Table 2 MPU values (N_min / tol, tol mapped by
reproduce_tables.PAPER_TOL_UNIT) change accuracy where the reproduction has an
analytic truth? J (branching cylinders, isoloft synth) is reconstructed with
today's defaults and with the paper's values and scored by `isoloft eval`
against its shape.json (two-sided distances in pixels, normal angles).

usage: table2_accuracy.py [--data DIR (reproduce_data.py's)] [--out DIR]
Writes OUT/table2_accuracy.{md,csv,json}.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402
import reproduce_tables as rt  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.path.join(ic.ROOT, "experiments", "out", "reproduce", "data"))
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "reproduce"))
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "scratch"), exist_ok=True)
    ds = ic.read_json(os.path.join(a.data, "J", "dataset.json"))
    run = ds["runs"][0]
    rows, res = [], {}
    for name, extra in (("today's defaults", []), ("paper Table 2", rt.paper_mpu_args(ds))):
        mesh = os.path.join(a.out, "scratch", "J_table2_%s.ply" % ("paper" if extra else "default"))
        ic.isoloft("reconstruct", *run["inputs"], *run["args"], *extra, "--method", "marker2006", "-o", mesh,
                   "--report", mesh + ".json", "--quiet")
        ic.isoloft("eval", "--mesh", mesh, "--truth", os.path.join(a.data, "J", "shape.json"), "--report",
                   mesh + ".eval.json")
        rep, ev = ic.read_json(mesh + ".json"), ic.read_json(mesh + ".eval.json")
        e = ev["mesh_to_truth"]["in_range"]  # between the first and last slice
        res[name] = {"args": extra, "mpu": rep["params"]["mpu"], "eval": ev, "total_s": rep["timings_s"]["total"],
                     "mpu_s": rep["timings_s"]["mpu"]}
        rows.append([name, rep["params"]["mpu"]["n_min"], "%.3g" % rep["params"]["mpu"]["tol"],
                     "%.3f" % e["mean_distance_px"], "%.3f" % e["p99_distance_px"], "%.3f" % e["max_distance_px"],
                     "%.2f" % e["mean_normal_angle_deg"], "%.2f" % rep["timings_s"]["mpu"],
                     "%.2f" % rep["timings_s"]["total"]])
    header = ["J (analytic truth)", "N_min", "tol (px)", "mean (px)", "p99 (px)", "max (px)", "normal (deg)",
              "MPU (s)", "total (s)"]
    rt.write_table(a.out, "table2_accuracy", header, rows)
    ic.write_json(os.path.join(a.out, "table2_accuracy.json"), res)
    print(rt.md_table(header, rows))


if __name__ == "__main__":
    main()
