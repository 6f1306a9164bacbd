"""RT-STRUCT input whose contours lie on planes a hair apart (issue 39's
audit: planes 1e-9 mm apart lost a contour in the RT output). The reader
joins planes closer than its tolerance into one plane at their mean height;
every contour drawn on either must come back in the RT output and be
accounted for in the per-contour report."""

import copy
import csv

import pydicom

from conftest import run_cli

PLANE_OFFSET_MM = 1e-9  # the audit's case: far below any DS rounding
SHIFT_MM = 200.0  # moves the copy clear of the Heart (about 90 mm across)
AREA_SHARE = 0.02  # a copy's section keeps its drawn area (resampling keeps 2 %)


def heart_with_a_copy_a_hair_above(src, dst):
    """The shared set's Heart, with its middle contour copied SHIFT_MM along
    x onto a plane PLANE_OFFSET_MM above; returns the plane's height."""
    ds = pydicom.dcmread(src)
    number = {r.ROIName: r.ROINumber for r in ds.StructureSetROISequence}["Heart"]
    roi = next(rc for rc in ds.ROIContourSequence if rc.ReferencedROINumber == number)
    copy_ = copy.deepcopy(roi.ContourSequence[len(roi.ContourSequence) // 2])
    data = [float(v) for v in copy_.ContourData]
    z = data[2]
    for i in range(0, len(data), 3):
        data[i] += SHIFT_MM
        data[i + 2] = z + PLANE_OFFSET_MM
    copy_.ContourData = [repr(v) for v in data]
    roi.ContourSequence.append(copy_)
    ds.save_as(dst)
    return z


def test_contours_on_planes_a_hair_apart_both_come_back(tmp_path, data_dir):
    src = tmp_path / "heart.dcm"
    z = heart_with_a_copy_a_hair_above(data_dir / "rtstruct" / "rtss.dcm", src)
    out = tmp_path / "out.dcm"
    run_cli("reconstruct", src, "--roi", "Heart", "-o", out, "-q", "--rt-contours", tmp_path / "c.csv")

    rows = [r for r in csv.DictReader(open(tmp_path / "c.csv")) if abs(float(r["z_mm"]) - z) < 0.01]
    assert len(rows) == 2, rows
    for r in rows:
        for flag in ("lost", "merged", "shrunk", "undrawn"):
            assert r[flag] == "false", (r["contour"], flag, r)
        drawn, section = float(r["area_drawn_mm2"]), float(r["area_section_mm2"])
        assert abs(section - drawn) <= AREA_SHARE * drawn, (r["contour"], drawn, section)

    written = pydicom.dcmread(out)
    on_plane = [c for rc in written.ROIContourSequence for c in rc.ContourSequence
                if abs(float(c.ContourData[2]) - z) < 0.01]
    assert len(on_plane) == 2, [len(c.ContourData) // 3 for c in on_plane]
