"""RT Structure Set cases from the hostile-file audit (issues 25, 27): plane
jitter, a contour off its plane, duplicate ROI names and numbers, ROIs by
number, a ROI on one plane. Each case is run by one or two `isoloft` binaries
(before / after) and reported as exit status, seconds, slices, components,
volume and the first line of stderr.

    /usr/bin/python3 experiments/rt_hostile.py [--before BIN] [--after BIN] [--out DIR]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402
from rt_kit import ellipse, write_rtstruct  # noqa: E402


def two_spheres(h=3.0, r=15.0, jitter=None, seed=1):
    """Two spheres of radius r side by side (two contours per plane), each contour's z jittered."""
    rng = np.random.default_rng(seed)
    planes = {}
    for k in range(-10, 11):
        z = k * h
        if abs(z) >= r:
            continue
        rr = math.sqrt(r * r - z * z)
        for cx in (-20.0, 20.0):
            dz = 0.0
            if jitter:
                dz = rng.choice([-1, 1]) * rng.uniform(*jitter)
            planes.setdefault(z + dz, []).append(ellipse(cx, 0, rr, rr, z + dz))
    return planes


def squares_with_island_off(h=3.0, off=0.02):
    """Two 10 mm squares per plane on 5 planes; on the middle plane one square written `off` mm above."""
    def sq(cx, z):
        return np.array([[cx - 5, -5, z], [cx + 5, -5, z], [cx + 5, 5, z], [cx - 5, 5, z]], dtype=float)
    planes = {}
    for k in range(5):
        z = k * h
        planes.setdefault(z, []).append(sq(-10, z))
        z2 = z + (off if k == 2 else 0.0)
        planes.setdefault(z2, []).append(sq(10, z2))
    return planes


def cases(d):
    out = []
    f = os.path.join(d, "island_off_plane.dcm")
    write_rtstruct(f, [("Lobes", squares_with_island_off())], TEMPLATE)
    out.append(("island 0.02 mm off its plane (2 objects)", [f]))
    f = os.path.join(d, "jitter.dcm")
    write_rtstruct(f, [("Lungs", two_spheres(jitter=(0.02, 0.04)))], TEMPLATE)
    out.append(("z jitter 0.02-0.04 mm, two spheres r 15 mm (28,274 mm^3)", [f]))
    f = os.path.join(d, "dup_names.dcm")
    write_rtstruct(f, [("Heart", two_spheres()), ("Heart", squares_with_island_off())], TEMPLATE)
    out.append(("two ROIs named Heart, --roi Heart", [f, "--roi", "Heart"]))
    out.append(("two ROIs named Heart, every ROI", [f]))
    f = os.path.join(d, "dup_numbers.dcm")
    write_rtstruct(f, [("A", two_spheres()), ("B", squares_with_island_off())], TEMPLATE, numbers=[5, 5])
    out.append(("two ROIs numbered 5, every ROI", [f]))
    out.append(("two ROIs numbered 5, --roi B", [f, "--roi", "B"]))
    rt = os.path.join(ic.ROOT, "data", "rtstruct", "rtss.dcm")
    out.append(("--roi 5 (Heart's number)", [rt, "--roi", "5"]))
    f = os.path.join(d, "one_plane.dcm")
    write_rtstruct(f, [("Dot", {0.0: [ellipse(0, 0, 2, 2, 0.0)]}), ("Ball", two_spheres())], TEMPLATE)
    out.append(("a ROI on one plane (4 mm disc) beside a 3 mm-spaced one, --roi Dot", [f, "--roi", "Dot"]))
    return out


TEMPLATE = os.path.join(ic.ROOT, "data", "rtstruct", "rtss.dcm")


def run_case(exe, args, d, tag):
    rep = os.path.join(d, "rep_%s.json" % tag)
    if os.path.exists(rep):
        os.remove(rep)
    t0 = time.time()
    r = subprocess.run([exe, "reconstruct", *args, "-o", os.path.join(d, "o_%s.ply" % tag), "--report", rep, "-q"],
                       capture_output=True, text=True)
    dt = time.time() - t0
    row = {"exit": r.returncode, "seconds": round(dt, 2), "message": (r.stderr.strip().splitlines() or [""])[0][:300]}
    if r.returncode == 0 and os.path.exists(rep):
        j = json.load(open(rep))
        row["slices"] = [o["planes"] for o in j["input"]["rois"]]
        row["objects"] = [(o.get("roi"), o["components"], round(o["volume"], 1), o["closed"]) for o in j["objects"]]
    return row


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before")
    ap.add_argument("--after", default=ic.isoloft_exe())
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "rt_hostile"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    results = []
    for i, (name, args) in enumerate(cases(a.out)):
        row = {"case": name}
        for tag, exe in (("before", a.before), ("after", a.after)):
            if exe:
                row[tag] = run_case(exe, args, a.out, "%d_%s" % (i, tag))
        results.append(row)
        print(json.dumps(row))
    ic.write_json(os.path.join(a.out, "results.json"), results)


if __name__ == "__main__":
    main()
