"""Analytic RT Structure Sets and the volumes isoloft gives them (issue 25).

Question: which end-cap rule (`--caps`) gives the right volume for small and
large structures at CT slice spacings, and how far is each from the truth
beside the slab rule (contour area x slice thickness) that planning systems
and dicompyler use?

The kit: spheres 3-30 mm, ellipsoids and axial cylinders (ending mid-slice),
each contoured the way a planning system does on a CT grid of spacing
h = 1, 2, 3 mm: on every plane z = k h the shape crosses, the exact
cross-section as a closed polygon of 128 vertices (ellipses, circles).
Each shape at several phases (its centre at a fraction of h off the grid),
since the volume of a sampled shape depends on where the planes cut it.
Written as RT Structure Sets with pydicom (Debian python3-pydicom) on the
header of data/rtstruct/rtss.dcm, one file per spacing, one ROI per shape.

    /usr/bin/python3 experiments/rt_kit.py [--caps dome,flat,...] [--out DIR]
        [--extra "--voxel-size 0.25"]

writes DIR/kit_h<h>.dcm, DIR/volumes.csv (one row per ROI, caps, spacing:
truth, isoloft and slab volumes in mm^3) and DIR/summary.md (the sphere table
and the other shapes per rule).
"""
import argparse
import copy
import csv
import math
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402

SPACINGS = (1.0, 2.0, 3.0)
PHASES = (0.0, 0.25, 0.5, 0.75)
SPHERES = (3, 4, 5, 6, 8, 10, 12, 15, 20, 25, 30)  # diameters, mm
VERTICES = 128
# Published planning-system ranges on analytic spheres 3-20 mm (JACMP 2021,
# PMC8248418, five systems): mean volume error per system, and single spheres.
PUBLISHED_MEAN = (-4.73, 1.15)
PUBLISHED_SPHERE = (-33.2, 9.5)
NARROWEST_SPHERE = (-10.9, 9.5)  # the target band (narrowest published range)


def ellipse(cx, cy, a, b, z, n=VERTICES):
    t = 2 * math.pi * np.arange(n) / n
    return np.stack([cx + a * np.cos(t), cy + b * np.sin(t), np.full(n, z)], axis=1)


def polygon_area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def shapes(h):
    """Every shape of the kit for spacing h: (name, kind, truth mm^3, {z: [polygon]})."""
    out = []

    def planes_of(zlo, zhi, section):
        planes = {}
        for k in range(math.floor(zlo / h) - 1, math.ceil(zhi / h) + 2):
            z = round(k * h, 6)
            if zlo < z < zhi:
                p = section(z)
                if p is not None:
                    planes[z] = [p]
        return planes

    x = 0.0
    for d in SPHERES:
        R = d / 2
        for ph in PHASES:
            c = ph * h
            sec = lambda z, c=c, R=R, x=x: ellipse(x, 0, math.sqrt(R * R - (z - c) ** 2), math.sqrt(R * R - (z - c) ** 2), z)
            planes = planes_of(c - R, c + R, sec)
            if planes:  # a sphere between two planes is not contoured at all
                out.append(("sphere_d%g_p%g" % (d, ph), "sphere", 4 / 3 * math.pi * R ** 3, planes, d))
            x += d + 10
    # Ellipsoids: semi-axes (a, b, c), c along z: elongated, flattened, in between.
    for a, b, cz in ((4, 4, 10), (10, 6, 3), (6, 4, 5), (12, 12, 6)):
        for ph in (0.0, 0.5):
            c = ph * h
            def sec(z, a=a, b=b, cz=cz, c=c, x=x):
                s = 1 - ((z - c) / cz) ** 2
                return ellipse(x, 0, a * math.sqrt(s), b * math.sqrt(s), z) if s > 0 else None
            out.append(("ellipsoid_%gx%gx%g_p%g" % (2 * a, 2 * b, 2 * cz, ph), "ellipsoid", 4 / 3 * math.pi * a * b * cz,
                        planes_of(c - cz, c + cz, sec), 2 * min(a, b, cz)))
            x += 2 * a + 10
    # Axial cylinders: radius r, length L, ends off the planes.
    for r, L in ((2.5, 10), (5, 20), (10, 15), (3, 7)):
        for ph in (0.25, 0.6):
            z0 = ph * h + 0.1
            sec = lambda z, r=r, x=x: ellipse(x, 0, r, r, z)
            out.append(("cylinder_r%g_L%g_p%g" % (r, L, ph), "cylinder", math.pi * r * r * L, planes_of(z0, z0 + L, sec),
                        min(2 * r, L)))
            x += 2 * r + 10
    return out


def slab_volume(planes, h):
    """Contour area x slice thickness (the planning systems' and dicompyler's rule)."""
    return sum(polygon_area(p) for polys in planes.values() for p in polys) * h


def write_rtstruct(path, rois, template, numbers=None):
    """An RT Structure Set with `rois` [(name, {z: [polygon (n, 3)]})] on the template's header
    (ROI numbers 1, 2, ... or `numbers`)."""
    import pydicom
    from pydicom.dataset import Dataset
    from pydicom.sequence import Sequence
    from pydicom.uid import generate_uid

    ds = pydicom.dcmread(template)
    ds.SOPInstanceUID = generate_uid()
    ds.file_meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
    ds.StructureSetLabel = "isoloft kit"
    frame = ds.StructureSetROISequence[0].ReferencedFrameOfReferenceUID
    ssroi, rcs, obs = Sequence(), Sequence(), Sequence()
    for i, (name, planes) in enumerate(rois, start=1):
        if numbers:
            i = numbers[i - 1]
        r = Dataset()
        r.ROINumber, r.ReferencedFrameOfReferenceUID, r.ROIName, r.ROIGenerationAlgorithm = i, frame, name, "MANUAL"
        ssroi.append(r)
        c = Dataset()
        c.ReferencedROINumber = i
        c.ROIDisplayColor = [(37 * i) % 256, (91 * i) % 256, (151 * i) % 256]
        seq = Sequence()
        for z in sorted(planes):
            for p in planes[z]:
                ct = Dataset()
                ct.ContourGeometricType = "CLOSED_PLANAR"
                ct.NumberOfContourPoints = len(p)
                ct.ContourData = ["%.4f" % v for v in p.reshape(-1)]
                seq.append(ct)
        c.ContourSequence = seq
        rcs.append(c)
        o = Dataset()
        o.ObservationNumber, o.ReferencedROINumber, o.RTROIInterpretedType, o.ROIInterpreter = i, i, "ORGAN", ""
        obs.append(o)
    ds.StructureSetROISequence, ds.ROIContourSequence, ds.RTROIObservationsSequence = ssroi, rcs, obs
    ds.save_as(path, write_like_original=False)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--caps", default="dome,flat")
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "rt_kit"))
    ap.add_argument("--extra", default="", help="more reconstruct flags")
    ap.add_argument("--spacings", default=",".join("%g" % h for h in SPACINGS))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    template = os.path.join(ic.ROOT, "data", "rtstruct", "rtss.dcm")
    rows = []
    for h in (float(s) for s in args.spacings.split(",")):
        kit = shapes(h)
        path = os.path.join(args.out, "kit_h%g.dcm" % h)
        write_rtstruct(path, [(name, planes) for name, _, _, planes, _ in kit], template)
        for caps in args.caps.split(","):
            rep = os.path.join(args.out, "report_h%g_%s.json" % (h, caps))
            cmd = [ic.isoloft_exe(), "reconstruct", path, "-o", os.path.join(args.out, "kit.ply"), "--report", rep, "-q",
                   "--caps", caps] + args.extra.split()
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
            got = {o["roi"]: o for o in ic.read_json(rep)["objects"]}
            for name, kind, truth, planes, size in kit:
                o = got.get(name)
                rows.append({"spacing": h, "caps": caps, "roi": name, "kind": kind, "size": size, "planes": len(planes),
                             "truth": truth, "isoloft": o["volume"] if o else float("nan"),
                             "closed": bool(o and o["closed"] and o["manifold"]), "slab": slab_volume(planes, h)})
    with open(os.path.join(args.out, "volumes.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    ic.write_text(os.path.join(args.out, "summary.md"), summary(rows))
    print(summary(rows))


def load(path):
    with open(path) as f:
        return [dict(r, spacing=float(r["spacing"]), size=float(r["size"]), planes=int(r["planes"]),
                     truth=float(r["truth"]), isoloft=float(r["isoloft"]), slab=float(r["slab"]),
                     closed=r["closed"] == "True") for r in csv.DictReader(f)]


def err(v, t):
    return 100.0 * (v - t) / t


def summary(rows):
    out = []
    caps_list = sorted({r["caps"] for r in rows})
    spacings = sorted({r["spacing"] for r in rows})
    out.append("Spheres: volume error %, mean over phases " + ", ".join("%g" % p for p in PHASES) +
               " (min..max); area*h = the slab rule (contour area x spacing)\n")
    head = "| d mm | " + " | ".join("h %g: %s" % (h, c) for h in spacings for c in caps_list + ["area*h"]) + " |"
    out.append(head)
    out.append("|" + "---|" * (1 + len(spacings) * (len(caps_list) + 1)))
    for d in SPHERES:
        cells = []
        for h in spacings:
            for c in caps_list + ["area*h"]:
                sel = [r for r in rows if r["kind"] == "sphere" and r["size"] == d and r["spacing"] == h and
                       r["caps"] == (c if c != "area*h" else caps_list[0])]
                e = [err(r["slab"] if c == "area*h" else r["isoloft"], r["truth"]) for r in sel]
                cells.append("%+.1f (%+.0f..%+.0f)" % (np.mean(e), min(e), max(e)))
        out.append("| %g | " % d + " | ".join(cells) + " |")
    out.append("")
    for c in caps_list + ["area*h"]:
        rs = [r for r in rows if r["caps"] == (c if c != "area*h" else caps_list[0])]
        def e_of(r):
            return err(r["slab"] if c == "area*h" else r["isoloft"], r["truth"])
        sph = [r for r in rs if r["kind"] == "sphere"]
        big = [abs(e_of(r)) for r in sph if r["size"] >= 8]
        small = [abs(e_of(r)) for r in sph if r["size"] <= 5]
        allsph = [e_of(r) for r in sph]
        other = [e_of(r) for r in rs if r["kind"] != "sphere"]
        closed = sum(r["closed"] for r in rs) if c != "area*h" else len(rs)
        out.append("%s: spheres mean %+.2f %%, range %+.1f..%+.1f %%, max |err| >= 8 mm %.1f %%, 3-5 mm %.1f %%; "
                   "ellipsoids+cylinders mean %+.2f %%, range %+.1f..%+.1f %%; closed %d/%d" %
                   (c, np.mean(allsph), min(allsph), max(allsph), max(big), max(small), np.mean(other), min(other),
                    max(other), closed, len(rs)))
    out.append("")
    out.append("Other shapes (error %, per spacing " + ", ".join("%g" % h for h in spacings) + "):\n")
    out.append("| shape | " + " | ".join(c for c in caps_list + ["area*h"]) + " |")
    out.append("|---|" + "---|" * (len(caps_list) + 1))
    names = sorted({r["roi"] for r in rows if r["kind"] != "sphere"})
    for n in names:
        cells = []
        for c in caps_list + ["area*h"]:
            es = []
            for h in spacings:
                r = [r for r in rows if r["roi"] == n and r["spacing"] == h and r["caps"] == (c if c != "area*h" else caps_list[0])][0]
                es.append("%+.1f" % err(r["slab"] if c == "area*h" else r["isoloft"], r["truth"]))
            cells.append(" / ".join(es))
        out.append("| %s | " % n + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    main()
