"""The RT Structure Set that `isoloft reconstruct rtss.dcm -o out.dcm` writes,
read back by readers other than isoloft's own: pydicom (every element with its
VR, every ContourData value a number, counts matching) and dicom3tools'
`dciodvfy` (the RT Structure Set IOD verified: no errors); its contours at
the density they were drawn, and the per-contour report (--rt-contours, the
report's "rtstruct_contours") accounting for every drawn contour."""

import csv
import json

import pydicom
import pytest

from conftest import dciodvfy_errors, run_cli

# ROIs of the shared set whose written contours passed Explicit VR's 65,534-byte
# limit (their ContourData came back as UN before the writer used Implicit VR),
# and a small one.
ROIS = ["BODY", "Lt Lung", "Heart"]
DS_MAX_CHARS = 16  # PS3.5 table 6.2-1


@pytest.fixture(scope="module")
def written(tmp_path_factory, data_dir):
    out = tmp_path_factory.mktemp("rt") / "out.dcm"
    args = ["reconstruct", data_dir / "rtstruct" / "rtss.dcm", "-o", out, "-q", "--rt-contours",
            out.with_suffix(".csv"), "--report", out.with_suffix(".json")]
    for roi in ROIS:
        args += ["--roi", roi]
    run_cli(*args)
    return data_dir / "rtstruct" / "rtss.dcm", out


def elements(ds):
    for e in ds:
        if e.VR == "SQ":
            for item in e.value:
                yield from elements(item)
        else:
            yield e


def test_pydicom_reads_every_element_with_its_vr(written):
    src, out = written
    ds = pydicom.dcmread(out)
    assert ds.file_meta.TransferSyntaxUID == pydicom.uid.ImplicitVRLittleEndian
    n = 0
    for e in elements(ds):
        n += 1
        assert e.VR != "UN", f"{e.tag} {e.name} has VR UN"
        if e.VR == "DS":
            values = e.value if isinstance(e.value, pydicom.multival.MultiValue) else [e.value]
            for i, v in enumerate(values):
                assert len(str(v.original_string if hasattr(v, "original_string") else v)) <= DS_MAX_CHARS, \
                    f"{e.tag} {e.name} value {i}: {v!r} is over 16 characters"
    assert n > 40
    names = {r.ROINumber: r.ROIName for r in ds.StructureSetROISequence}
    assert sorted(names.values()) == sorted(ROIS)
    contours = 0
    for rc in ds.ROIContourSequence:
        for k, c in enumerate(rc.ContourSequence):
            data = [float(v) for v in c.ContourData]
            assert c.NumberOfContourPoints >= 3, f"ROI {names[rc.ReferencedROINumber]} contour {k}"
            assert len(data) == 3 * c.NumberOfContourPoints, f"ROI {names[rc.ReferencedROINumber]} contour {k}"
            contours += 1
    assert contours > 100
    # The referenced frame of reference and series: the input's.
    before = pydicom.dcmread(src)
    ref_in, ref_out = before.ReferencedFrameOfReferenceSequence[0], ds.ReferencedFrameOfReferenceSequence[0]
    assert ref_out.FrameOfReferenceUID == ref_in.FrameOfReferenceUID
    assert ds.FrameOfReferenceUID == ref_in.FrameOfReferenceUID
    series = lambda r: r.RTReferencedStudySequence[0].RTReferencedSeriesSequence[0].SeriesInstanceUID
    assert series(ref_out) == series(ref_in)
    assert ds.StudyInstanceUID == before.StudyInstanceUID and ds.SeriesInstanceUID != before.SeriesInstanceUID


def test_dciodvfy_finds_no_error(written):
    _, out = written
    errors = dciodvfy_errors(out)
    assert not errors, "dciodvfy:\n" + "\n".join(errors)


# The targets for the round trip, per ROI: written points within this
# factor of the drawn ones, and the mean distance between the drawn contours
# and their written sections on their planes.
POINTS_FACTOR = 1.5
MEAN_DISTANCE_MM = 0.1


def test_contours_come_back_at_the_density_they_were_drawn(written):
    src, out = written
    report = json.loads(out.with_suffix(".json").read_text())["rtstruct_contours"]
    drawn = pydicom.dcmread(src)
    names = {r.ROINumber: r.ROIName for r in drawn.StructureSetROISequence}
    points_in = {names[rc.ReferencedROINumber]: sum(int(c.NumberOfContourPoints) for c in rc.ContourSequence)
                 for rc in drawn.ROIContourSequence if names[rc.ReferencedROINumber] in ROIS}
    ds = pydicom.dcmread(out)
    points_out = {names[rc.ReferencedROINumber]: sum(int(c.NumberOfContourPoints) for c in rc.ContourSequence)
                  for rc in ds.ROIContourSequence}
    for roi in ROIS:
        ratio = points_out[roi] / points_in[roi]
        assert 1 / POINTS_FACTOR <= ratio <= POINTS_FACTOR, f"ROI {roi}: {points_in[roi]} points in, {points_out[roi]} out"
    for s in report["rois"]:
        assert s["points_in"] == points_in[s["roi"]] and s["points_out"] == points_out[s["roi"]], s["roi"]
        assert s["mean_distance_mm"] <= MEAN_DISTANCE_MM, f"ROI {s['roi']}: {s['mean_distance_mm']} mm"
        assert 0 < s["resample_mean_deviation_mm"] <= s["resample_max_deviation_mm"], s["roi"]


def test_every_drawn_contour_is_accounted_for(written, tmp_path, data_dir):
    src, out = written
    rows = list(csv.DictReader(out.with_suffix(".csv").open()))
    report = json.loads(out.with_suffix(".json").read_text())["rtstruct_contours"]
    assert len(rows) == len(report["contours"])
    drawn = pydicom.dcmread(src)
    names = {r.ROINumber: r.ROIName for r in drawn.StructureSetROISequence}
    for rc in drawn.ROIContourSequence:
        roi = names[rc.ReferencedROINumber]
        if roi not in ROIS:
            continue
        listed = {int(r["contour"]) for r in rows if r["roi"] == roi and int(r["contour"]) > 0}
        assert listed == set(range(1, len(rc.ContourSequence) + 1)), f"ROI {roi}: contours missing from the report"
    for r in rows:
        where = f"ROI {r['roi']} z {r['z_mm']} contour {r['contour']}"
        if r["lost"] == "true":  # not on the surface: written back as drawn (nothing dropped without --rt-min-area)
            assert r["written"] == "drawn" and float(r["area_section_mm2"]) == float(r["area_drawn_mm2"]), where
        if r["undrawn"] == "true":
            assert int(r["contour"]) == 0 and float(r["area_section_mm2"]) > 0, where
    # BODY's islands at z = -101.44 (34.4, 24.3 and 39.5 mm^2, drawn on that
    # plane alone): each one on the surface (its working grid's planes, 0.94
    # mm apart, run through every drawn plane), none shrunk beyond 25 %.
    islands = [r for r in rows if r["roi"] == "BODY" and abs(float(r["z_mm"]) + 101.44) < 0.01
               and 20 < float(r["area_drawn_mm2"]) < 45]
    assert len(islands) == 3, islands
    for r in islands:
        assert r["written"] == "section" and r["lost"] == "false" and r["shrunk"] == "false", r
    # Every drawn contour of 1 mm^2 or more is on the surface.
    big_lost = [r for r in rows if r["lost"] == "true" and float(r["area_drawn_mm2"]) >= 1]
    assert not big_lost, big_lost


def test_min_area_drops_lost_contours_and_names_them(tmp_path, data_dir):
    out = tmp_path / "lung.dcm"
    r = run_cli("reconstruct", data_dir / "rtstruct" / "rtss.dcm", "--roi", "Lt Lung", "-o", out, "--rt-min-area", "0.5",
                "--rt-contours", tmp_path / "lung.csv")
    rows = list(csv.DictReader((tmp_path / "lung.csv").open()))
    dropped = [row for row in rows if row["written"] == "dropped"]
    assert dropped and all(float(row["area_drawn_mm2"]) < 0.5 and row["lost"] == "true" for row in dropped)
    for row in dropped:
        assert f"contour {row['contour']} at z = " in r.stderr, f"contour {row['contour']} dropped without a warning"


def test_point_spacing_as_keyword_and_flag(tmp_path, data_dir):
    isoloft = pytest.importorskip("isoloft")
    rtss = data_dir / "rtstruct" / "rtss.dcm"
    res = isoloft.reconstruct(rtss, roi="Scar", rtstruct=tmp_path / "py.dcm", rt_point_spacing=0.5)
    py = res.report["rtstruct_contours"]["rois"][0]
    run_cli("reconstruct", rtss, "--roi", "Scar", "-o", tmp_path / "cli.dcm", "--rt-point-spacing", "0.5",
            "--report", tmp_path / "cli.json")
    cli = json.loads((tmp_path / "cli.json").read_text())["rtstruct_contours"]["rois"][0]
    # Scar was drawn about 0.85 mm apart: at 0.5 mm, more points, each section's
    # step the asked one within what rounding n = length / step to whole points gives.
    assert py["points_out"] == cli["points_out"] > py["points_in"]
    assert py["point_spacing_mm"] == pytest.approx(0.5, rel=0.05)
    with pytest.raises(isoloft.ParamError, match="rt_point_spacing"):
        isoloft.reconstruct(rtss, roi="Scar", rt_point_spacing=0.5)


def test_volume_table_says_how_far_each_volume_can_be_trusted(tmp_path, data_dir):
    r = run_cli("reconstruct", data_dir / "rtstruct" / "rtss.dcm", "--roi", "Borders", "--roi", "Heart", "-o",
                tmp_path / "rt.ply", "--volumes", tmp_path / "v.csv")
    rows = {row["name"]: row for row in csv.DictReader((tmp_path / "v.csv").open())}
    borders, heart = rows["Borders"], rows["Heart"]
    assert int(borders["planes"]) == 2 and float(borders["spacing"]) == pytest.approx(3.0, abs=0.01)
    # Two planes 3 mm apart: the caps (half a spacing beyond each) are about
    # half the volume; Heart on 33 planes has about 1/33 of it there.
    assert 0.3 < float(borders["cap_share"]) < 0.7 and "on 2 planes" in borders["warning"]
    assert 0 < float(heart["cap_share"]) < 0.05 and heart["warning"] == ""
    assert "warning: 'Borders' on 2 planes" in r.stdout
