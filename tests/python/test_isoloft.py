"""`import isoloft`: every input kind gives the CLI's mesh bytes for the same
input, parameters by keyword, errors, threads, progress, the GIL, no leak."""

import json
import pathlib
import threading

import numpy as np
import pytest

import isoloft
from conftest import run_cli

# Frog slices used where the whole stack would only cost time: 6 slices of
# 500x470 labels still have several organs and an end cap at both ends.
FROG_SLICES = 6
FROG_Z_SPACING = 6


def read_bytes(path):
    return pathlib.Path(path).read_bytes()


def assert_same_files(a_files, b_files):
    """Pairwise equal bytes (the lists in the same order: each object, then the combined mesh)."""
    assert len(a_files) == len(b_files) > 0
    for a, b in zip(a_files, b_files):
        assert read_bytes(a) == read_bytes(b), f"{a} and {b} differ"


def cli_reconstruct(tmp_path, name, *args):
    out = tmp_path / f"cli_{name}.ply"
    report = tmp_path / f"cli_{name}.json"
    run_cli("reconstruct", *args, "-o", out, "--report", report, "--quiet")
    return out, json.loads(report.read_text())


def comparable(objects):
    """Report objects without the file names (the CLI's and ours differ by name)."""
    return [{k: v for k, v in o.items() if k != "file"} for o in objects]


@pytest.fixture(scope="module")
def sphere_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("sphere")
    run_cli("synth", "sphere", "--z-spacing", 8, "--out", d)
    return d


@pytest.fixture(scope="module")
def frog_files(data_dir):
    return sorted(str(p) for p in (data_dir / "frog").glob("frog_*.png"))[:FROG_SLICES]


# ---------------------------------------------------------------- same bytes as the CLI, every input kind

def test_contour_arrays_give_the_cli_mesh_bytes(tmp_path, sphere_dir):
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "sphere", sphere_dir, "--z-spacing", 8)
    stack = isoloft.synth("sphere", z_spacing=8)
    assert stack.slices.dtype == np.uint8 and stack.slices.ndim == 3
    res = isoloft.reconstruct(stack.slices, z_spacing=8)  # the plain numpy path
    files = res.save(tmp_path / "py.ply")
    assert_same_files(files, [cli_mesh])
    assert comparable(res.report["objects"]) == comparable(cli_report["objects"])
    assert res.report["params"] == cli_report["params"]
    assert set(res.report) == set(cli_report)
    # A list of 2D arrays and the Input itself are the same stack.
    assert isoloft.reconstruct(list(stack.slices), z_spacing=8).objects[0].faces.tolist() == res.objects[0].faces.tolist()
    again = isoloft.reconstruct(stack)
    again.objects[0].save(tmp_path / "again.ply")
    assert read_bytes(tmp_path / "again.ply") == read_bytes(cli_mesh)


def test_vertices_and_faces_are_the_written_mesh(tmp_path, sphere_dir):
    meshio = pytest.importorskip("meshio")
    cli_mesh, _ = cli_reconstruct(tmp_path, "sphere", sphere_dir, "--z-spacing", 8, "--pixel-size", 0.5)
    obj = isoloft.reconstruct(isoloft.synth("sphere", z_spacing=8).slices, z_spacing=8, pixel_size=0.5).objects[0]
    written = meshio.read(cli_mesh)
    assert obj.vertices.dtype == np.float64 and obj.vertices.shape[1] == 3
    assert np.array_equal(obj.vertices, written.points.astype(np.float64))
    assert np.array_equal(obj.faces, written.cells_dict["triangle"])
    # meshio takes the arrays as they are (the README's example).
    meshio.Mesh(obj.vertices, [("triangle", obj.faces)]).write(tmp_path / "m.vtu")
    back = meshio.read(tmp_path / "m.vtu")
    assert np.array_equal(back.points, obj.vertices) and np.array_equal(back.cells_dict["triangle"], obj.faces)


def test_faces_view_the_cpp_buffer_read_only():
    obj = isoloft.reconstruct(isoloft.synth("sphere", size=64, z_spacing=8)).objects[0]
    faces = obj.faces
    assert not faces.flags.owndata and faces.base is not None  # a view, not a copy
    assert faces.dtype == np.int32 and faces.flags.c_contiguous
    with pytest.raises(ValueError):
        faces[0, 0] = 1  # read-only: save() writes what the arrays show
    del obj
    assert faces.max() < 2**31  # the view keeps the C++ mesh alive


def test_mask_arrays_give_the_cli_mesh_bytes(tmp_path):
    d = tmp_path / "masks"
    run_cli("synth", "torus", "--kind", "masks", "--z-spacing", 6, "--out", d)
    cli_mesh, _ = cli_reconstruct(tmp_path, "masks", d, "--z-spacing", 6, "--input", "masks")
    stack = isoloft.synth("torus", z_spacing=6, kind="masks")
    files = isoloft.reconstruct(stack.slices > 0, z_spacing=6, input="masks").save(tmp_path / "py.ply")  # bool array
    assert_same_files(files, [cli_mesh])


def test_label_arrays_give_the_cli_meshes(tmp_path, frog_files):
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "frog", *frog_files, "--input", "labels", "--z-spacing",
                                           FROG_Z_SPACING)
    frog = isoloft.read(frog_files, input="labels", z_spacing=FROG_Z_SPACING)
    assert frog.slices.shape == (FROG_SLICES, 470, 500)
    # The labels as plain integers, as numpy code would hold them.
    res = isoloft.reconstruct(frog.slices.astype(np.int64), input="labels", z_spacing=FROG_Z_SPACING)
    files = res.save(tmp_path / "py.ply")
    cli_files = [o["file"] for o in cli_report["objects"]] + [str(cli_mesh)]
    assert len(res.objects) == len(cli_report["objects"]) > 1
    assert [o.label for o in res.objects] == [o["label"] for o in cli_report["objects"]]
    assert_same_files(files, cli_files)
    # Straight from the read input: also the CLI's report entries.
    direct = isoloft.reconstruct(frog)
    assert comparable(direct.report["objects"]) == comparable(cli_report["objects"])
    assert direct.report["input"]["format"] == "png" and direct.report["input"]["kind"] == "labels"


def test_labels_selects_objects(frog_files):
    frog = isoloft.read(frog_files, input="labels", z_spacing=FROG_Z_SPACING)
    first = isoloft.reconstruct(frog).objects[0].label
    only = isoloft.reconstruct(frog, labels=[first])
    assert [o.label for o in only.objects] == [first]


def test_polygons_give_the_cli_mesh_bytes(tmp_path):
    d = tmp_path / "poly"
    run_cli("synth", "torus", "--kind", "polylines", "--out", d)
    cli_mesh, _ = cli_reconstruct(tmp_path, "poly", d / "stack.txt")
    stack = isoloft.synth("torus", kind="polylines")
    assert stack.slices is None and all(p.shape[1] == 2 for loops in stack.polygons for p in loops)
    res = isoloft.reconstruct(stack.polygons, input="polylines", slice_z=stack.slice_z,
                              image_shape=stack.shape[1:])
    assert_same_files(res.save(tmp_path / "py.ply"), [cli_mesh])
    assert_same_files(isoloft.reconstruct(isoloft.read(d / "stack.txt")).save(tmp_path / "file.ply"), [cli_mesh])


def write_sparse_label_volume(path):
    """Two labels on every other axial slice, 1 x 1 x 2 mm voxels, x flipped,
    as a MetaImage (the simplest volume format to write by hand)."""
    nx, ny, nz = 40, 36, 11
    k, j, i = np.mgrid[0:nz, 0:ny, 0:nx]
    v = np.zeros((nz, ny, nx), np.uint8)
    drawn = (k % 2 == 1) & (k < nz - 1)
    v[drawn & (np.hypot(i - 14.0, j - 17.0) < 8.0 - np.abs(k - 5.0))] = 4
    v[drawn & (i > 26) & (i < 33) & (j > 10) & (j < 26)] = 9
    header = (f"ObjectType = Image\nNDims = 3\nDimSize = {nx} {ny} {nz}\nElementType = MET_UCHAR\n"
              "ElementSpacing = 1 1 2\nOffset = -20 15 40\nTransformMatrix = -1 0 0 0 1 0 0 0 1\n"
              "ElementDataFile = LOCAL\n")
    pathlib.Path(path).write_bytes(header.encode() + v.tobytes())


def test_volume_file_gives_the_cli_meshes_in_patient_space(tmp_path):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "vol", vol, "--space", "ras")
    inp = isoloft.read(vol, space="ras")
    assert inp.format == "volume" and inp.kind == "labels" and inp.space == "RAS"
    assert inp.annotated_slices == [1, 3, 5, 7, 9]
    # Working pixels are the 1 mm in-plane voxels (x flipped); slice z = index * 2 mm / 1 mm.
    assert np.array_equal(inp.patient_axes, np.diag([-1.0, 1.0, 1.0]))
    assert list(inp.slice_z) == [2, 6, 10, 14, 18]
    res = isoloft.reconstruct(inp)
    cli_files = [o["file"] for o in cli_report["objects"]] + [str(cli_mesh)]
    assert_same_files(res.save(tmp_path / "py.ply"), cli_files)
    assert b"comment SPACE=RAS" in read_bytes(tmp_path / "py.ply")[:200]
    # Patient mm: z between the first and last annotated slice's planes (40 + 2 k mm), capped half a spacing beyond.
    z = np.concatenate([o.vertices[:, 2] for o in res.objects])
    assert z.min() >= 40 + 2 * 1 - 2 and z.max() <= 40 + 2 * 9 + 2
    assert res.report["input"]["space"] == "RAS"


def test_rtstruct_gives_the_cli_mesh_bytes(tmp_path, data_dir):
    rtss = data_dir / "rtstruct" / "rtss.dcm"
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "heart", rtss, "--roi", "Heart", "--method", "levin",
                                           "--volumes", tmp_path / "cli.csv")
    inp = isoloft.read(rtss, roi=5)  # by number: the Heart
    assert inp.format == "rtstruct" and inp.names == ["Heart"] and inp.space == "LPS"
    res = isoloft.reconstruct(inp, method="levin", volumes=tmp_path / "py.csv", rtstruct=tmp_path / "py.dcm")
    assert res.objects[0].roi == "Heart"
    assert_same_files(res.save(tmp_path / "py.ply"), [cli_mesh])
    assert comparable(res.report["objects"]) == comparable(cli_report["objects"])
    # The volume table (issue 25): the CLI's, with the slab volume beside the surface's.
    assert res.report["volumes"] == cli_report["volumes"]
    row = res.report["volumes"][0]
    assert (row["name"], row["number"], row["planes"], row["closed"]) == ("Heart", 5, 33, True)
    assert row["volume_mm3"] > 0 and row["slab_volume_mm3"] > 0
    assert read_bytes(tmp_path / "py.csv") == read_bytes(tmp_path / "cli.csv")
    # The RT Structure Set out (its contents are checked in io/test_rtstruct.cpp): the Heart, by its number.
    assert res.report["rtstruct"] == str(tmp_path / "py.dcm")
    assert isoloft.read(tmp_path / "py.dcm", roi=5).names == ["Heart"]
    # Patient mm, as the CLI test checks: inside the Heart's contour range.
    assert res.objects[0].vertices[:, 2].min() > -101 and res.objects[0].vertices[:, 2].max() < 1



def test_rtstruct_labelmap_on_a_reference_grid(tmp_path, data_dir):
    """labelmap= with reference= (issue 25): the CLI's label map, on the reference's grid."""
    nib = pytest.importorskip("nibabel")
    rtss = data_dir / "rtstruct" / "rtss.dcm"
    # A CT-like grid around Scar (ROI 8) as NIfTI stores one: RAS, i towards
    # the patient's left (LPS +x), j posterior, 3 mm slices on its contour planes.
    affine = np.array([[-1.0, 0, 0, -120.3], [0, -1.0, 0, 345.2], [0, 0, 3.0, -26.44], [0, 0, 0, 1]])
    nib.save(nib.Nifti1Image(np.zeros((25, 50, 9), np.int16), affine), tmp_path / "ct.nii.gz")
    res = isoloft.reconstruct(rtss, roi="Scar", reference=tmp_path / "ct.nii.gz", labelmap=tmp_path / "py.nii.gz")
    run_cli("reconstruct", rtss, "--roi", "Scar", "-o", tmp_path / "cli.ply", "--reference", tmp_path / "ct.nii.gz",
            "--labelmap", tmp_path / "cli.nii.gz")
    py, cli = nib.load(tmp_path / "py.nii.gz"), nib.load(tmp_path / "cli.nii.gz")
    assert np.allclose(py.affine, affine, atol=1e-4) and py.shape == (25, 50, 9)
    labels = np.asarray(py.dataobj)
    assert np.array_equal(labels, np.asarray(cli.dataobj))
    assert set(np.unique(labels)) == {0, 8}
    row = res.report["labelmap_labels"][0]
    assert row["label"] == 8 and row["labelled_voxels"] == int((labels == 8).sum())
    with pytest.raises(isoloft.ParamError, match="reference: gives the grid of a label map; give labelmap"):
        isoloft.reconstruct(rtss, roi="Scar", reference=tmp_path / "ct.nii.gz")
    (tmp_path / "notes.txt").write_text("not an image")
    with pytest.raises(isoloft.InputError, match="notes.txt: not a reference grid"):
        isoloft.reconstruct(rtss, roi="Scar", reference=tmp_path / "notes.txt", labelmap=tmp_path / "x.nii.gz")
    assert not (tmp_path / "x.nii.gz").exists()


# ---------------------------------------------------------------- parameters

def test_parameters_by_keyword_match_the_cli_flags(tmp_path, sphere_dir):
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "p", sphere_dir, "--z-spacing", 8, "--n-min", 100,
                                           "--spline", "natural", "--no-filter")
    res = isoloft.reconstruct(isoloft.synth("sphere", z_spacing=8), mpu={"n_min": 100},
                              interp={"spline": "natural"}, filter={"enabled": False})
    assert res.report["params"] == cli_report["params"]
    assert_same_files(res.save(tmp_path / "py.ply"), [cli_mesh])


def test_default_params_are_the_cli_print_params():
    printed = run_cli("reconstruct", "--print-params").stdout
    lines = [l for l in printed.splitlines() if not l.lstrip().startswith("//")]
    assert isoloft.default_params() == json.loads("\n".join(lines))
    assert "n_min" in isoloft.describe_params()


@pytest.mark.parametrize("params, named", [
    ({"mpu": {"bogus": 1}}, "mpu.bogus"),
    ({"bogus": 1}, "bogus"),
    ({"mpu": {"n_min": -1}}, "mpu.n_min"),
    ({"mpu": {"n_min": 2.5}}, "mpu.n_min"),
    ({"mpu": {"tol": float("nan")}}, "mpu.tol"),
    ({"method": "marching"}, "method"),
    ({"interp": {"spline": 3}}, "interp.spline"),
])
def test_bad_parameters_raise_naming_them(params, named):
    stack = isoloft.synth("sphere", size=64)
    with pytest.raises(isoloft.ParamError, match=named.replace(".", r"\.")) as e:
        isoloft.reconstruct(stack, **params)
    assert isinstance(e.value, ValueError)


def test_numpy_scalars_are_parameters():
    stack = isoloft.synth("sphere", size=64)
    res = isoloft.reconstruct(stack, mpu={"n_min": np.int64(40), "tol": np.float64(0.01)}, binarize=np.bool_(True))
    assert res.report["params"]["mpu"]["n_min"] == 40 and res.report["params"]["mpu"]["tol"] == 0.01
    assert res.report["params"]["binarize"] is True


# ---------------------------------------------------------------- bad input

@pytest.mark.parametrize("slices, kwargs, problem", [
    (np.zeros((3, 8, 8), np.float32), {}, "slices\\[0\\].*dtype float32"),
    (np.zeros((8, 8), np.uint8), {}, "expected an \\(n, h, w\\) array"),
    ([np.zeros((8, 8), np.uint8), np.zeros((9, 8), np.uint8)], {}, "slices\\[1\\].*differs"),
    (np.stack([np.arange(64, dtype=np.uint8).reshape(8, 8)] * 3), {"input": "contours"},
     "slices\\[0\\].*neither 0 nor 255"),
    (np.full((3, 8, 8), -1, np.int32), {"input": "labels"}, "slices\\[0\\].*negative"),
    (np.zeros((1, 8, 8), np.uint8), {}, "at least 2 slices"),
    (np.zeros((3, 8, 8), np.uint8), {}, "nothing to reconstruct"),
    ("no/such/dir", {}, "no/such/dir"),
])
def test_bad_input_raises_naming_it(slices, kwargs, problem):
    with pytest.raises(isoloft.InputError, match=problem) as e:
        isoloft.reconstruct(slices, **kwargs)
    assert isinstance(e.value, ValueError) and isinstance(e.value, isoloft.Error)


def test_options_the_input_cannot_use_raise(tmp_path, data_dir):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    with pytest.raises(isoloft.ParamError, match="z_spacing/slice_z: a volume carries its own voxel spacing"):
        isoloft.read(vol, z_spacing=2)
    with pytest.raises(isoloft.ParamError, match="roi/voxel_size: only with a DICOM RT Structure Set"):
        isoloft.read(vol, roi="Heart")
    with pytest.raises(isoloft.InputError, match="no ROI named or numbered 'Liver'"):
        isoloft.read(data_dir / "rtstruct" / "rtss.dcm", roi="Liver")
    with pytest.raises(isoloft.ParamError, match="z_spacing: the Input already holds"):
        isoloft.reconstruct(isoloft.read(vol), z_spacing=3)
    with pytest.raises(isoloft.ParamError, match="labels: only with label input"):
        isoloft.reconstruct(isoloft.synth("sphere", size=64), labels=[2])
    with pytest.raises(isoloft.ParamError, match="give either z_spacing or slice_z"):
        isoloft.reconstruct(isoloft.synth("sphere", size=64).slices, z_spacing=2, slice_z=[0, 1])
    with pytest.raises(isoloft.ParamError, match="unknown value 'banana'"):
        isoloft.reconstruct(np.zeros((2, 8, 8), np.uint8), input="banana")


# ---------------------------------------------------------------- threads, progress, GIL

def test_threads_give_the_same_bytes(tmp_path):
    stack = isoloft.synth("tilted-torus", z_spacing=6)
    one = isoloft.reconstruct(stack, threads=1)
    many = isoloft.reconstruct(stack, threads=2)
    assert one.report["threads"] == 1 and many.report["threads"] == 2
    one.save(tmp_path / "one.ply")
    many.save(tmp_path / "many.ply")
    assert read_bytes(tmp_path / "one.ply") == read_bytes(tmp_path / "many.ply")
    with pytest.raises(isoloft.ParamError, match=r"threads: 0 is out of range \(1 \.\. "):
        isoloft.reconstruct(stack, threads=0)


def test_progress_is_called_per_stage_up_to_its_total():
    calls = []
    isoloft.reconstruct(isoloft.synth("sphere", z_spacing=8), progress=calls.append)
    stages = {}
    for p in calls:
        stage, done, total = p.stage, p.stage_done, p.stage_total
        assert isinstance(stage, str) and 0 <= done <= total
        stages[stage] = max(stages.get(stage, (0, 0)), (done, total))
    # The streamed pipeline's stages: contour masks, the per-slice fit, distance
    # and filter (one batch), then interpolation and meshing plane by plane.
    assert set(stages) == {"contour", "mpu+distance", "interpolate+mesh"}, stages
    assert all(done == total for done, total in stages.values()), stages


def test_progress_raising_stops_the_run():
    class Stop(Exception):
        pass

    def stop(p):
        raise Stop(p.stage)

    with pytest.raises(Stop):
        isoloft.reconstruct(isoloft.synth("sphere", z_spacing=8), progress=stop)
    assert isoloft.reconstruct(isoloft.synth("sphere", size=64)).objects  # still usable after


def test_the_gil_is_released_while_the_library_works():
    stack = isoloft.synth("torus", size=192, z_spacing=4)
    ticks = [0]
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks[0] += 1

    t = threading.Thread(target=count)
    t.start()
    try:
        before = ticks[0]
        isoloft.reconstruct(stack)
        during = ticks[0] - before
    finally:
        done.set()
        t.join()
    # With the GIL held for the whole call the counting thread could not run at all.
    assert during > 1000, during


# ---------------------------------------------------------------- evaluate, no leak

def test_evaluate_matches_the_cli_eval(tmp_path, sphere_dir):
    cli_mesh, _ = cli_reconstruct(tmp_path, "sphere", sphere_dir, "--z-spacing", 8)
    cli_eval = json.loads(run_cli("eval", "--mesh", cli_mesh, "--truth", sphere_dir / "shape.json").stdout)
    stack = isoloft.synth("sphere", z_spacing=8)
    obj = isoloft.reconstruct(stack).objects[0]
    assert isoloft.evaluate(obj, stack) == cli_eval["mesh_to_truth"]
    assert isoloft.evaluate((obj.vertices, obj.faces), sphere_dir / "shape.json") == cli_eval["mesh_to_truth"]
    assert stack.truth["shape"]["type"] == "sphere"
    with pytest.raises(isoloft.InputError, match="faces must be an \\(M, 3\\) array"):
        isoloft.evaluate((obj.vertices, obj.faces[:, :2]), stack)


def rss_mib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


# Growth of resident memory allowed over 100 calls after warm-up: the
# allocator's and TBB's caches settle in the warm-up; keeping each call's
# result, stack and arrays alive would cost LEAK_PER_CALL_MIB * 100 (checked
# below to exceed this bound, so the test can see such a leak).
MAX_RSS_GROWTH_MIB = 8.0


def test_no_leak_across_100_calls():
    stack = isoloft.synth("torus", size=96, z_spacing=6)
    for _ in range(10):
        isoloft.reconstruct(stack, progress=lambda *a: None)
    base = rss_mib()
    for _ in range(100):
        res = isoloft.reconstruct(stack.slices, z_spacing=6, progress=lambda *a: None)
        obj = res.objects[0]
        _ = (obj.vertices.sum(), obj.faces.sum(), res.report)
    growth = rss_mib() - base
    leak_per_call = (obj.vertices.nbytes + obj.faces.nbytes + obj.vertices.nbytes / 2 + stack.slices.nbytes * 4) / 2**20
    assert leak_per_call * 100 > MAX_RSS_GROWTH_MIB
    assert growth < MAX_RSS_GROWTH_MIB, f"resident memory grew {growth:.1f} MiB over 100 calls"


# ---------------------------------------------------------------- the CLI's other outputs, one run path

def test_volume_labelmap_and_report_are_the_cli_files(tmp_path):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    run_cli("reconstruct", vol, "-o", tmp_path / "cli.ply", "--volume", tmp_path / "cli.nrrd", "--labelmap",
            tmp_path / "cli_map.nii.gz", "--report", tmp_path / "cli.json", "--quiet")
    res = isoloft.reconstruct(vol, volume=tmp_path / "py.nrrd", labelmap=tmp_path / "py_map.nii.gz",
                              report=tmp_path / "py.json")
    for label in (4, 9):
        assert read_bytes(tmp_path / f"py_label{label}.nrrd") == read_bytes(tmp_path / f"cli_label{label}.nrrd")
    assert read_bytes(tmp_path / "py_map.nii.gz") == read_bytes(tmp_path / "cli_map.nii.gz")
    written = json.loads((tmp_path / "py.json").read_text())
    assert written["volume_files"] == [str(tmp_path / f"py_label{label}.nrrd") for label in (4, 9)]
    assert written["labelmap"] == str(tmp_path / "py_map.nii.gz") and res.report["labelmap"] == written["labelmap"]
    cli = json.loads((tmp_path / "cli.json").read_text())
    assert comparable(written["objects"]) == comparable(cli["objects"])


def test_a_keyword_the_run_never_reads_is_refused_as_the_cli_refuses_its_flag(tmp_path):
    stack = isoloft.synth("sphere", size=64)
    with pytest.raises(isoloft.ParamError, match=r"mpu\.n_min: has no effect here, only with .*isoloft, marker2006"):
        isoloft.reconstruct(stack, method="levin", mpu={"n_min": 100})
    with pytest.raises(isoloft.ParamError, match="polyline_raster_width: has no effect here, only with a polyline input"):
        isoloft.reconstruct(stack, polyline_raster_width=256)
    with pytest.raises(isoloft.ParamError, match="label_partition: has no effect here, only with label input"):
        isoloft.reconstruct(stack, label_partition=True)
    assert not list(tmp_path.iterdir())


def test_output_options_refused_as_the_cli_refuses_them(tmp_path):
    stack = isoloft.synth("sphere", size=64)
    with pytest.raises(isoloft.ParamError, match="labelmap: only with a volume input"):
        isoloft.reconstruct(stack, labelmap=tmp_path / "x.nii.gz")
    with pytest.raises(isoloft.ParamError, match="volume: '.*x.vtk' must end in .nrrd"):
        isoloft.reconstruct(stack, volume=tmp_path / "x.vtk")
    with pytest.raises(isoloft.ParamError, match="dump_stages: has no effect here"):
        isoloft.reconstruct(stack, method="levin", dump_stages=tmp_path / "d")
    with pytest.raises(isoloft.ParamError, match="max_memory: .* needs about .* over the budget"):
        isoloft.reconstruct(stack, max_memory="1K")
    with pytest.raises(isoloft.ParamError, match="max_output: .* with volume needs about"):
        isoloft.reconstruct(stack, volume=tmp_path / "v.nrrd", max_output="10K")
    assert not list(tmp_path.iterdir())  # nothing half-written
