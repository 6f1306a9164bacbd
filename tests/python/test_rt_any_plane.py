"""RT Structure Set contours on oblique planes (issue 35 item 1): with
--method field3d each ROI is read as sections on its contours' own planes
(io/rtstruct_sections.h) and reconstructed in patient mm; the column methods
keep refusing them with the reader's error naming the ROI and the contour;
RT output writes the mesh cut by each input plane, on that plane; a contour
off its plane is an error naming ROI and contour."""

import copy
import json

import numpy as np
import pydicom
import pytest

from conftest import CLI, run_cli
import subprocess

RADIUS = 30.0  # mm, the synthetic ROI's sphere
CENTRE = np.array([10.0, -150.0, -60.0])  # near the shared set's Heart, in its patient space
POINTS = 180  # per contour
# field3d's grid: 48 cells, coarser than the default 96 (what is checked
# holds at either; a test run stays short).
FIELD3D = {"field3d": {"resolution": 48}}


def tilted_poses():
    """Three mutually orthogonal planes through CENTRE, none axial nor
    sagittal nor coronal: the identity's axes turned 30 degrees about x then
    40 about z."""
    a, b = np.radians(30), np.radians(40)
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
    r = rz @ rx
    return [(r[:, i], r[:, (i + 1) % 3]) for i in range(3)]


def sphere_on_tilted_planes(src, dst, roi_name="Heart", bend_mm=0.0):
    """The shared set with ROI `roi_name`'s contours replaced by a sphere's
    circles on three tilted orthogonal planes; `bend_mm` lifts one point of
    the second contour off its plane."""
    ds = pydicom.dcmread(src)
    number = {r.ROIName: r.ROINumber for r in ds.StructureSetROISequence}[roi_name]
    roi = next(rc for rc in ds.ROIContourSequence if rc.ReferencedROINumber == number)
    template = copy.deepcopy(roi.ContourSequence[0])
    if "ContourImageSequence" in template:
        del template.ContourImageSequence  # an oblique contour lies on no CT slice
    contours = []
    a = 2 * np.pi * np.arange(POINTS) / POINTS
    for k, (u, v) in enumerate(tilted_poses()):
        pts = CENTRE + RADIUS * (np.cos(a)[:, None] * u + np.sin(a)[:, None] * v)
        if k == 1 and bend_mm:
            pts[7] += bend_mm * np.cross(u, v)
        c = copy.deepcopy(template)
        c.ContourGeometricType = "CLOSED_PLANAR"
        c.NumberOfContourPoints = POINTS
        c.ContourData = [f"{x:.6f}" for x in pts.ravel()]
        contours.append(c)
    roi.ContourSequence = contours
    ds.save_as(dst)


@pytest.fixture
def oblique(tmp_path, data_dir):
    path = tmp_path / "oblique.dcm"
    sphere_on_tilted_planes(data_dir / "rtstruct" / "rtss.dcm", path)
    return path


@pytest.fixture
def params(tmp_path):
    path = tmp_path / "params.json"
    path.write_text(json.dumps(FIELD3D))
    return path


def run_fails(*args):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert r.returncode != 0, f"isoloft {' '.join(map(str, args))} succeeded"
    return r.stderr


def test_field3d_reads_oblique_rt_contours_as_sections(tmp_path, oblique, params):
    out, rep = tmp_path / "heart.obj", tmp_path / "rep.json"
    run_cli("reconstruct", oblique, "--roi", "Heart", "--method", "field3d", "--params", params, "-o", out,
            "--report", rep, "-q")
    report = json.loads(rep.read_text())
    assert report["input"]["rois"] == [{"name": "Heart", "planes": 3, "any_plane": True}]
    ob = report["objects"][0]
    assert ob["closed"] and ob["manifold"] and ob["oriented"], ob
    assert ob["components"] == 1 and ob["euler_characteristic"] == 2, ob
    # In patient mm, about the sphere: measured 0.956 R to 1.022 R from its
    # centre (the field extrapolates between three circles); 0.9 to 1.1 R
    # tells patient mm from any other frame.
    pts = np.array([[float(x) for x in line.split()[1:4]] for line in open(out) if line.startswith("v ")])
    assert len(pts) == ob["vertices"]
    r = np.linalg.norm(pts - CENTRE, axis=1)
    assert r.max() < 1.1 * RADIUS and r.min() > 0.9 * RADIUS, (r.min(), r.max())


def test_column_methods_refuse_oblique_rt_contours(tmp_path, oblique):
    err = run_fails("reconstruct", oblique, "--roi", "Heart", "-o", tmp_path / "a.ply", "-q")
    assert "ROI 'Heart' contour 0 lies on an oblique plane" in err, err
    assert not (tmp_path / "a.ply").exists()


# The written sections follow the drawn circles (contour samples weigh 100
# per cell): measured 0.030 mm at most from radius RADIUS at 48 cells
# (0.0084 mm at 96), against a grid cell of 1.5 mm; 0.1 mm holds that with
# room and stays far below a cell.
RING_TOL_MM = 0.1
# Written points off their input plane: the 32-bit float mesh cut in the
# plane's frame and the DS strings; measured 7.6e-5 mm.
ON_PLANE_MM = 1e-3


def test_rt_output_on_the_oblique_input_planes(tmp_path, oblique, params):
    out, rep = tmp_path / "b.dcm", tmp_path / "rep.json"
    run_cli("reconstruct", oblique, "--roi", "Heart", "--method", "field3d", "--params", params, "-o", out,
            "--report", rep, "-q")
    written = pydicom.dcmread(out)
    [roi] = written.ROIContourSequence
    assert len(roi.ContourSequence) == 3
    normals = [np.cross(u, v) for u, v in tilted_poses()]
    for k, c in enumerate(roi.ContourSequence):
        pts = np.array([float(x) for x in c.ContourData]).reshape(-1, 3)
        assert "ContourImageSequence" not in c
        heights = (pts - CENTRE) @ normals[k]
        assert np.abs(heights).max() < ON_PLANE_MM, (k, np.abs(heights).max())
        ring = np.abs(np.linalg.norm(pts - CENTRE, axis=1) - RADIUS)
        assert ring.max() <= RING_TOL_MM, (k, ring.max())
    summary = json.loads(rep.read_text())["rtstruct_contours"]["rois"][0]
    assert summary["contours_out"] == 3 and summary["max_distance_mm"] <= RING_TOL_MM, summary
    # The written set reads back as the same three planes.
    run_cli("reconstruct", out, "--method", "field3d", "--params", params, "-o", tmp_path / "again.ply",
            "--report", tmp_path / "again.json", "-q")
    again = json.loads((tmp_path / "again.json").read_text())
    assert again["input"]["rois"][0]["planes"] == 3 and again["objects"][0]["euler_characteristic"] == 2


def test_a_contour_off_its_plane_names_the_roi_and_the_contour(tmp_path, data_dir, params):
    src = tmp_path / "bent.dcm"
    sphere_on_tilted_planes(data_dir / "rtstruct" / "rtss.dcm", src, bend_mm=0.5)
    err = run_fails("reconstruct", src, "--roi", "Heart", "--method", "field3d", "--params", params, "-o",
                    tmp_path / "c.ply", "-q")
    assert "ROI 'Heart' contour 1: not planar" in err, err
    assert not (tmp_path / "c.ply").exists()


def test_python_reads_oblique_rt_contours_for_field3d(oblique):
    import isoloft
    res = isoloft.reconstruct(oblique, roi="Heart", method="field3d", **FIELD3D)
    [ob] = res.objects
    assert ob.roi == "Heart" and ob.report["closed"] and ob.report["euler_characteristic"] == 2, ob.report
    r = np.linalg.norm(ob.vertices - CENTRE, axis=1)
    assert r.max() < 1.1 * RADIUS and r.min() > 0.9 * RADIUS, (r.min(), r.max())
    with pytest.raises(isoloft.InputError, match="ROI 'Heart' contour 0 lies on an oblique plane"):
        isoloft.read(oblique, roi="Heart")
