"""What reconstruct() gives back: progress per object, VTK files (.vtp,
.vtk) that VTK reads, and meshio / pyvista / trimesh objects."""

import sys
import types

import numpy as np
import pytest

import isoloft
from conftest import run_cli
from test_isoloft import FROG_SLICES, FROG_Z_SPACING, read_bytes


@pytest.fixture(scope="module")
def frog(data_dir):
    files = sorted(str(p) for p in (data_dir / "frog").glob("frog_*.png"))[:FROG_SLICES]
    return isoloft.read(files, input="labels", z_spacing=FROG_Z_SPACING)


# ---------------------------------------------------------------- progress

def test_progress_per_object_only_grows_and_ends_at_its_total(frog):
    events = []
    res = isoloft.reconstruct(frog, progress=events.append)
    by_object = {}
    for p in events:
        assert isinstance(p, isoloft.Progress) and 0 <= p.done <= p.total
        assert 0 <= p.stage_done <= p.stage_total
        by_object.setdefault(p.label, []).append(p)
    labels = [o.label for o in res.objects]
    assert set(labels) <= set(by_object) and 0 in by_object  # 0: the label scan every label shares
    for label in labels:
        steps = by_object[label]
        done = [p.done for p in steps]
        assert done == sorted(done), f"label {label}: done went back: {done}"
        assert steps[-1].done == steps[-1].total, f"label {label} ends at {steps[-1]}"
        assert [s for s in dict.fromkeys(p.stage for p in steps)] == ["mpu+distance", "interpolate+mesh"]


def test_progress_bars_draw_one_bar_per_object(frog, capsys):
    pytest.importorskip("tqdm")
    isoloft.reconstruct(frog, labels=[frog_label(frog)], progress=isoloft.progress_bars())
    err = capsys.readouterr().err
    assert f"label {frog_label(frog)}" in err and "100%" in err


def frog_label(frog):
    return int(np.unique(frog.slices)[-1])


# ---------------------------------------------------------------- VTK files

def read_vtk(path):
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy
    reader = vtk.vtkXMLPolyDataReader() if str(path).endswith(".vtp") else vtk.vtkPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    poly = reader.GetOutput()
    points = vtk_to_numpy(poly.GetPoints().GetData())
    cells = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    cell_data = {poly.GetCellData().GetArrayName(i): vtk_to_numpy(poly.GetCellData().GetArray(i))
                 for i in range(poly.GetCellData().GetNumberOfArrays())}
    point_data = {poly.GetPointData().GetArrayName(i): vtk_to_numpy(poly.GetPointData().GetArray(i))
                  for i in range(poly.GetPointData().GetNumberOfArrays())}
    space = poly.GetFieldData().GetAbstractArray("SPACE")
    header = reader.GetHeader() if hasattr(reader, "GetHeader") else None
    return points, cells, cell_data, point_data, (space.GetValue(0) if space else None), header


@pytest.mark.parametrize("ext", [".vtp", ".vtk"])
def test_vtk_files_load_in_vtk_with_normals_labels_and_space(tmp_path, frog, ext):
    res = isoloft.reconstruct(frog)
    files = res.save(tmp_path / f"frog{ext}")
    for obj, path in zip(res.objects, files):
        points, cells, cell_data, _, _, _ = read_vtk(path)
        assert np.array_equal(points, obj.vertices.astype(np.float32)) and np.array_equal(cells, obj.faces)
        assert np.all(cell_data["Label"] == obj.label)
        v = obj.vertices[obj.faces]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        assert np.allclose(cell_data["Normals"], n, atol=1e-5)
    points, cells, cell_data, point_data, _, _ = read_vtk(files[-1])  # the combined mesh
    assert len(cells) == sum(len(o.faces) for o in res.objects)
    assert np.array_equal(np.unique(cell_data["Label"]), sorted(o.label for o in res.objects))
    assert point_data["Colors"].shape == (len(points), 3)
    # The CLI writes the same bytes.
    run_cli("reconstruct", *frog.files, "--input", "labels", "--z-spacing", FROG_Z_SPACING, "-o",
            tmp_path / f"cli{ext}", "-q")
    assert read_bytes(tmp_path / f"cli{ext}") == read_bytes(files[-1])


def test_vtk_files_name_the_patient_space_as_slicer_reads_it(tmp_path, data_dir):
    heart = isoloft.reconstruct(data_dir / "rtstruct" / "rtss.dcm", roi="Heart", voxel_size=2, method="levin",
                                space="ras")
    obj = heart.objects[0]
    obj.save(tmp_path / "heart.vtp")
    obj.save(tmp_path / "heart.vtk", ascii=True)
    points, _, cell_data, _, space, _ = read_vtk(tmp_path / "heart.vtp")
    assert space == "RAS" and np.array_equal(points, obj.vertices.astype(np.float32))
    assert np.all(cell_data["Label"] == 1)  # an ROI: its place in the input
    points, _, _, _, _, header = read_vtk(tmp_path / "heart.vtk")
    assert "SPACE=RAS" in header and np.allclose(points, obj.vertices, atol=1e-4)


# ---------------------------------------------------------------- conversions

def test_to_meshio_keeps_the_arrays_and_labels(frog):
    pytest.importorskip("meshio")
    res = isoloft.reconstruct(frog)
    one = res.objects[0].to_meshio()
    assert np.array_equal(one.points, res.objects[0].vertices)
    assert np.array_equal(one.cells_dict["triangle"], res.objects[0].faces)
    both = res.to_meshio()
    assert len(both.cells_dict["triangle"]) == sum(len(o.faces) for o in res.objects)
    assert set(np.unique(both.cell_data["label"][0])) == {o.label for o in res.objects}


def fake_module(name, **attrs):
    """A stand-in for a library this machine lacks, recording what it is given."""
    m = types.ModuleType(name)
    for k, v in attrs.items():
        setattr(m, k, v)
    return m


def test_to_pyvista_and_to_trimesh_pass_the_documented_layouts(monkeypatch, frog):
    """pyvista and trimesh are not Debian packages: where they are missing,
    stand-ins check the call each documents (PolyData(points, faces) with
    faces as [3, a, b, c, ...]; Trimesh(vertices=, faces=, process=False))."""
    obj = isoloft.reconstruct(frog, labels=[frog_label(frog)]).objects[0]
    if "pyvista" not in sys.modules:
        try:
            import pyvista  # noqa: F401
        except ImportError:
            class PolyData:
                def __init__(self, points, faces):
                    self.points, self.faces, self.cell_data = points, faces, {}
            monkeypatch.setitem(sys.modules, "pyvista", fake_module("pyvista", PolyData=PolyData))
    pv = obj.to_pyvista()
    assert np.array_equal(np.asarray(pv.points), obj.vertices)
    faces = np.asarray(pv.faces).reshape(-1, 4)
    assert np.all(faces[:, 0] == 3) and np.array_equal(faces[:, 1:], obj.faces)
    assert np.all(np.asarray(pv.cell_data["label"]) == obj.label)
    try:
        import trimesh  # noqa: F401
    except ImportError:
        class Trimesh:
            def __init__(self, vertices, faces, face_attributes, process):
                self.vertices, self.faces, self.face_attributes, self.process = vertices, faces, face_attributes, process
        monkeypatch.setitem(sys.modules, "trimesh", fake_module("trimesh", Trimesh=Trimesh))
    tm = obj.to_trimesh()
    assert np.array_equal(np.asarray(tm.vertices), obj.vertices) and np.array_equal(np.asarray(tm.faces), obj.faces)
    assert np.all(tm.face_attributes["label"] == obj.label)
