#!/usr/bin/env python3
"""The AAL atlas with its names through every output (issue 38): every 4th
axial slice of Debian mricron-data's aal.nii.gz (the others emptied, as
experiments/batch_cases.py annotates it sparsely) with aal.nii.txt beside it,
reconstructed with meshes (-o OUT.ply), the report, the volume table and an
RT Structure Set. Checks that each label's name from the table is the same
in the mesh file name, the report's objects, the volume CSV, the RT
Structure Set's ROI names and the VTP field data; that every RT contour
point lies on its label's pixel outline on its slice, mapped back through
the NIfTI affine; and runs dciodvfy on the RT Structure Set. Prints one JSON line (counts, mismatches, dciodvfy's
errors and warnings, the run's wall time); exits 1 on any mismatch or
dciodvfy error.

Usage: tests/aal_names_roundtrip.py [--cli build/isoloft] [--labels 1,2,3] [--keep DIR]
(tests/python/test_rtstruct_labels.py runs it on a few labels.)"""

import argparse
import csv
import json
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import time

AAL = pathlib.Path("/usr/share/mricron/templates/aal.nii.gz")
AAL_TABLE = AAL.with_name("aal.nii.txt")
EVERY = 4  # every 4th axial slice kept (the project's sparse AAL, experiments/batch_cases.py)
# An RT contour point farther than this (voxels) from its label's pixel
# outline on its slice lies in a neighbouring pixel: the contours are checked
# against the label map itself through the NIfTI affine (LPS -> RAS: x and y
# negated), which catches a flipped or shifted patient space.
OUTLINE_VOXELS = 0.5


def outline_distances(ds, labels, affine):
    """|signed distance| (voxels) of every RT contour point to its label's
    pixel outline (half a voxel beyond the pixel centres) on its slice; the
    largest distance of a point off its slice's plane (voxels)."""
    import numpy as np
    from scipy import ndimage
    inv = np.linalg.inv(affine)
    out, off_plane = [], 0.0
    for rc in ds.ROIContourSequence:
        label = int(rc.ReferencedROINumber)
        for c in rc.get("ContourSequence", []):
            lps = np.array([float(v) for v in c.ContourData]).reshape(-1, 3)
            ijk = (inv[:3, :3] @ (lps * [-1, -1, 1]).T).T + inv[:3, 3]
            k = int(round(ijk[0, 2]))
            off_plane = max(off_plane, float(np.abs(ijk[:, 2] - k).max()))
            inside = labels[:, :, k] == label
            signed = np.where(inside, ndimage.distance_transform_edt(inside) - 0.5,
                              0.5 - ndimage.distance_transform_edt(~inside))
            out.extend(np.abs(ndimage.map_coordinates(signed, [ijk[:, 0], ijk[:, 1]], order=1)))
    return np.array(out), off_plane


def file_safe(name):
    # The mesh file names' sanitiser (core/sanitize.h file_safe): [A-Za-z0-9_-], others '_', 64 bytes.
    return re.sub(r"[^A-Za-z0-9_-]", "_", name)[:64]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", default=str(pathlib.Path(__file__).resolve().parents[1] / "build" / "isoloft"))
    ap.add_argument("--labels", default="", help="only these labels (comma-separated); default all 116")
    ap.add_argument("--keep", default="", help="write into this folder and keep it")
    a = ap.parse_args()
    import nibabel as nib
    import numpy as np
    import pydicom

    d = pathlib.Path(a.keep) if a.keep else pathlib.Path(tempfile.mkdtemp(prefix="aal_names_"))
    d.mkdir(parents=True, exist_ok=True)
    aal = nib.load(AAL)
    labels = np.asarray(aal.dataobj).copy()
    labels[:, :, np.arange(labels.shape[2]) % EVERY != 0] = 0
    nii = d / "aal_every4.nii.gz"
    nib.save(nib.Nifti1Image(labels, aal.affine), nii)
    shutil.copy(AAL_TABLE, d / "aal_every4.nii.txt")  # beside it, as mricron ships it
    table = {int(line.split()[0]): line.split()[1] for line in AAL_TABLE.read_text().splitlines() if line.strip()}
    wanted = sorted(int(x) for x in a.labels.split(",")) if a.labels else sorted(table)
    names = {k: table[k] for k in wanted}

    args = [a.cli, "reconstruct", str(nii), "-o", str(d / "aal.vtp"), "--rtstruct", str(d / "aal.dcm"),
            "--report", str(d / "aal.json"), "--volumes", str(d / "aal.csv"), "-q"]
    if a.labels:
        args += ["--labels", a.labels]
    t0 = time.perf_counter()
    r = subprocess.run(args, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if r.returncode != 0:
        print(r.stderr, file=sys.stderr)
        return 1

    mismatches = []
    files = {int(m.group(1)): m.group(2) for p in d.glob("aal_label*.vtp")
             if (m := re.fullmatch(r"aal_label(\d+)_(.*)\.vtp", p.name))}
    mismatches += [f"mesh file of label {k}: {files.get(k)!r}, want {file_safe(v)!r}" for k, v in names.items()
                   if files.get(k) != file_safe(v)]
    report = json.loads((d / "aal.json").read_text())
    in_report = {o["label"]: o.get("name") for o in report["objects"]}
    mismatches += [f"report label {k}: {in_report.get(k)!r}" for k, v in names.items() if in_report.get(k) != v]
    with (d / "aal.csv").open(encoding="utf-8") as f:
        in_csv = {int(row["number"]): row["name"] for row in csv.DictReader(f)}
    mismatches += [f"volume CSV label {k}: {in_csv.get(k)!r}" for k, v in names.items() if in_csv.get(k) != v]
    ds = pydicom.dcmread(d / "aal.dcm")
    in_rt = {int(roi.ROINumber): str(roi.ROIName) for roi in ds.StructureSetROISequence}
    mismatches += [f"RT ROI {k}: {in_rt.get(k)!r}" for k, v in names.items() if in_rt.get(k) != v]
    contours = sum(len(rc.ContourSequence) for rc in ds.ROIContourSequence if "ContourSequence" in rc)
    points = sum(int(c.NumberOfContourPoints) for rc in ds.ROIContourSequence if "ContourSequence" in rc
                 for c in rc.ContourSequence)
    dist, off_plane = outline_distances(ds, labels, aal.affine)
    outline = {"median": round(float(np.median(dist)), 3), "p95": round(float(np.percentile(dist, 95)), 3),
               "max": round(float(dist.max()), 3), "off_plane": off_plane}
    if outline["max"] > OUTLINE_VOXELS or off_plane > OUTLINE_VOXELS:
        mismatches.append(f"RT contours off their labels' outlines: {outline} voxels")
    try:
        import vtk
        for k, v in names.items():
            reader = vtk.vtkXMLPolyDataReader()
            reader.SetFileName(str(d / f"aal_label{k}_{file_safe(v)}.vtp"))
            reader.Update()
            fd = reader.GetOutput().GetFieldData()
            got = fd.GetAbstractArray("label_name")
            if got is None or got.GetValue(0) != v or fd.GetAbstractArray("label").GetValue(0) != k:
                mismatches.append(f"VTP field data of label {k}: {got.GetValue(0) if got else None!r}")
        vtp_checked = True
    except ImportError:
        vtp_checked = False
    verdict = {"errors": None, "warnings": None}
    if shutil.which("dciodvfy"):
        v = subprocess.run(["dciodvfy", str(d / "aal.dcm")], capture_output=True, text=True)
        lines = (v.stdout + v.stderr).splitlines()
        verdict = {"iod": "RTStructureSet" in lines,
                   "errors": [x for x in lines if x.startswith("Error")],
                   "warnings": sorted({re.sub(r"\d+", "N", x) for x in lines if x.startswith("Warning")})}
    print(json.dumps({"labels": len(names), "mesh_files": len(files), "report_names": len(in_report),
                      "csv_names": len(in_csv), "rt_rois": len(in_rt), "rt_contours": contours, "rt_points": points,
                      "outline_distance_voxels": outline,
                      "vtp_field_data_checked": vtp_checked, "mismatches": mismatches, "dciodvfy": verdict,
                      "seconds": round(seconds, 2), "rt_bytes": (d / "aal.dcm").stat().st_size}))
    if not a.keep:
        shutil.rmtree(d)
    return 1 if mismatches or verdict["errors"] else 0


if __name__ == "__main__":
    sys.exit(main())
