"""What reconstruct() is given: arrays whose kind is inferred or refused,
nibabel and SimpleITK-like images with their geometry, and paths read with
every read() option."""

import pathlib

import numpy as np
import pytest

import isoloft
from conftest import run_cli
from test_isoloft import (FROG_SLICES, FROG_Z_SPACING, assert_same_files, cli_reconstruct, read_bytes,
                          write_sparse_label_volume)

# The ball: radius 20 px (33,510 px^3), its masks every BALL_Z_SPACING px.
BALL_RADIUS = 20.0
BALL_Z_SPACING = 2
# The target for the mesh's volume against the closed form. Measured:
# -0.4 % at 2 px (21 slices), -1.9 % at 4 px, -9.3 % at 8 px (the end caps'
# share grows with the spacing); read as contour curves (the old default):
# -26 %, 37 components.
BALL_VOLUME_TOLERANCE = 0.02


def ball_masks():
    y, x = np.mgrid[0:64, 0:64]
    zs = np.arange(-BALL_RADIUS, BALL_RADIUS + 1, BALL_Z_SPACING)
    return np.stack([(x - 31.5) ** 2 + (y - 31.5) ** 2 + z ** 2 <= BALL_RADIUS ** 2 for z in zs])


def test_a_bool_ball_without_input_is_read_as_masks():
    res = isoloft.reconstruct(ball_masks(), z_spacing=BALL_Z_SPACING)
    assert res.report["input"]["kind"] == "masks"
    (o,) = res.report["objects"]
    truth = 4 / 3 * np.pi * BALL_RADIUS ** 3
    assert o["components"] == 1 and o["closed"]
    assert abs(o["volume"] - truth) <= BALL_VOLUME_TOLERANCE * truth, (o["volume"], truth)


def test_a_0_1_uint8_mask_needs_no_binarize_and_binarize_works():
    masks = ball_masks()
    as_bool = isoloft.reconstruct(masks, z_spacing=BALL_Z_SPACING)
    zero_one = isoloft.reconstruct(masks.astype(np.uint8), z_spacing=BALL_Z_SPACING)
    binarized = isoloft.reconstruct(masks.astype(np.uint8), z_spacing=BALL_Z_SPACING, input="masks", binarize=True)
    for r in (zero_one, binarized):
        assert r.objects[0].faces.tolist() == as_bool.objects[0].faces.tolist()
    # A gray image thresholded at half its range, the kind then inferred from the white.
    gray = np.where(masks, 200, 40).astype(np.uint8)
    assert isoloft.reconstruct(gray, z_spacing=BALL_Z_SPACING, binarize=True).objects[0].faces.tolist() == \
        as_bool.objects[0].faces.tolist()


def test_contour_curves_without_input_are_contours(tmp_path):
    d = tmp_path / "sphere"
    run_cli("synth", "sphere", "--size", 64, "--z-spacing", 8, "--out", d)
    cli_mesh, _ = cli_reconstruct(tmp_path, "sphere", d, "--z-spacing", 8)
    curves = isoloft.synth("sphere", size=64, z_spacing=8).slices > 0
    res = isoloft.reconstruct(curves, z_spacing=8)
    assert res.report["input"]["kind"] == "contours"
    assert_same_files(res.save(tmp_path / "py.ply"), [cli_mesh])


def test_integer_labels_without_input_are_labels(data_dir):
    files = sorted(str(p) for p in (data_dir / "frog").glob("frog_*.png"))[:FROG_SLICES]
    frog = isoloft.read(files, input="labels", z_spacing=FROG_Z_SPACING)
    inferred = isoloft.reconstruct(frog.slices.astype(np.int32), z_spacing=FROG_Z_SPACING)
    assert inferred.report["input"]["kind"] == "labels" and len(inferred.objects) > 1
    given = isoloft.reconstruct(frog)
    assert [o.label for o in inferred.objects] == [o.label for o in given.objects]
    assert all(a.faces.tolist() == b.faces.tolist() for a, b in zip(inferred.objects, given.objects))


def test_ambiguous_arrays_are_refused_naming_the_argument():
    blobs = np.zeros((3, 32, 32), bool)
    blobs[:, 4:7, 4:7] = True  # a 3x3 blob: one pixel in nine has a white 3x3 neighbourhood
    blobs[:, 20, 2:30] = True  # and a line
    with pytest.raises(isoloft.InputError, match=r"give input='masks' or input='contours'"):
        isoloft.reconstruct(blobs)
    assert isoloft.reconstruct(blobs, input="masks", allow_empty=True).report["input"]["kind"] == "masks"


def test_hints_name_python_arguments():
    gray = np.zeros((2, 16, 16), np.uint8)
    gray[:, 4:12, 4:12] = 100
    gray[:, 6:10, 6:10] = 255
    with pytest.raises(isoloft.InputError, match=r"use input='labels' for label images, or binarize=True"):
        isoloft.reconstruct(gray, input="masks")
    with pytest.raises(isoloft.ParamError, match=r"labels: only with label input \(input='labels'"):
        isoloft.reconstruct(isoloft.synth("sphere", size=64), labels=[2])


# ---------------------------------------------------------------- images with their geometry

def test_a_nibabel_image_gives_the_cli_mesh_of_its_file(tmp_path):
    nib = pytest.importorskip("nibabel")
    mha = tmp_path / "labels.mha"
    write_sparse_label_volume(mha)
    # The same labels as NIfTI: voxel (i, j, k) -> RAS; the MetaImage's LPS x flip becomes no flip in RAS.
    header = mha.read_bytes().split(b"ElementDataFile = LOCAL\n")[0]
    data = np.frombuffer(mha.read_bytes()[len(header) + len(b"ElementDataFile = LOCAL\n"):], np.uint8)
    labels = data.reshape(11, 36, 40).transpose(2, 1, 0)
    affine = np.array([[1.0, 0, 0, 20], [0, -1, 0, -15], [0, 0, 2, 40], [0, 0, 0, 1]])
    nii = tmp_path / "labels.nii.gz"
    nib.save(nib.Nifti1Image(labels, affine), nii)
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "nii", nii)
    res = isoloft.reconstruct(nib.load(nii))
    assert res.report["input"]["format"] == "volume" and res.report["input"]["space"] == "LPS"
    cli_files = [o["file"] for o in cli_report["objects"]] + [str(cli_mesh)]
    assert_same_files(res.save(tmp_path / "py.ply"), cli_files)


class DuckImage:
    """What reconstruct() asks of a SimpleITK image: origin, spacing and
    direction (LPS, row-major), and the voxels as a (k, j, i) array."""

    def __init__(self, voxels, origin, spacing, direction):
        self._voxels, self._origin, self._spacing, self._direction = voxels, origin, spacing, direction

    def GetOrigin(self):
        return self._origin

    def GetSpacing(self):
        return self._spacing

    def GetDirection(self):
        return self._direction

    def __array__(self, dtype=None):
        return self._voxels if dtype is None else self._voxels.astype(dtype)


def test_a_simpleitk_like_image_gives_the_cli_mesh_of_its_file(tmp_path):
    mha = tmp_path / "labels.mha"
    write_sparse_label_volume(mha)  # 40 x 36 x 11, spacing 1 1 2, origin -20 15 40, x flipped
    raw = mha.read_bytes()
    voxels = np.frombuffer(raw[raw.index(b"LOCAL\n") + 6:], np.uint8).reshape(11, 36, 40)
    image = DuckImage(voxels, (-20.0, 15.0, 40.0), (1.0, 1.0, 2.0), (-1, 0, 0, 0, 1, 0, 0, 0, 1))
    cli_mesh, cli_report = cli_reconstruct(tmp_path, "mha", mha, "--space", "ras")
    res = isoloft.reconstruct(image, space="ras")
    cli_files = [o["file"] for o in cli_report["objects"]] + [str(cli_mesh)]
    assert_same_files(res.save(tmp_path / "py.ply"), cli_files)
    assert isoloft.read(image).annotated_slices == [1, 3, 5, 7, 9]
    with pytest.raises(isoloft.ParamError, match="z_spacing: an image carries its own voxel geometry"):
        isoloft.reconstruct(image, z_spacing=2)


def test_every_read_option_works_on_a_path(tmp_path, data_dir):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    direct = isoloft.reconstruct(vol, space="ras", axis="k", input="labels")
    via_read = isoloft.reconstruct(isoloft.read(vol, space="ras", axis="k", input="labels"))
    assert direct.report["input"] == via_read.report["input"] and direct.report["input"]["space"] == "RAS"
    assert_same_files(direct.save(tmp_path / "a.ply"), via_read.save(tmp_path / "b.ply"))
    rtss = data_dir / "rtstruct" / "rtss.dcm"
    heart = isoloft.reconstruct(rtss, roi="Heart", voxel_size=2, method="levin")
    assert [o.roi for o in heart.objects] == ["Heart"] and heart.report["input"]["rois"][0]["name"] == "Heart"
    with pytest.raises(isoloft.ParamError, match="axis: only with a volume, an image or an RT Structure Set"):
        isoloft.reconstruct(np.zeros((2, 8, 8), bool), axis="k")
    with pytest.raises(isoloft.ParamError, match="roi/voxel_size: only with a DICOM RT Structure Set"):
        isoloft.reconstruct(vol, roi="Heart")


# ---------------------------------------------------------------- hostile arguments (issue 39)

def _sparse_voxels(tmp_path):
    mha = tmp_path / "labels.mha"
    write_sparse_label_volume(mha)
    raw = mha.read_bytes()
    return np.frombuffer(raw[raw.index(b"LOCAL\n") + 6:], np.uint8).reshape(11, 36, 40)


@pytest.mark.parametrize("direction, origin, message", [
    ((1, 0, 0, 1), (0, 0, 0), r"GetDirection\(\) gives 4 values, expected 9"),
    ((1, 0, 0, 0, 1, 0, 0, 0, 1), ("a", "b", "c"), r"GetOrigin\(\) is not numbers"),
    ((1, 0, 0, 0, 1, 0, 0, 0, 1), (0, 0, float("nan")), r"the origin is not finite"),
    ((1, 1, 0, 0, 0, 0, 0, 0, 1), (0, 0, 0), r"voxel axes i and j are not orthogonal"),
    ((2, 0, 0, 0, 1, 0, 0, 0, 1), (0, 0, 0), r"the direction of voxel axis i is not a finite unit vector"),
])
def test_a_bad_image_geometry_is_an_input_error_naming_it(tmp_path, direction, origin, message):
    image = DuckImage(_sparse_voxels(tmp_path), origin, (1.0, 1.0, 2.0), direction)
    with pytest.raises(isoloft.InputError, match=message):
        isoloft.reconstruct(image)


@pytest.mark.parametrize("affine, message", [
    (np.diag([1.0, 1.0, 0.0, 1.0]), r"singular or not finite \(voxel axis k has length 0"),
    (np.array([[1.0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]]), r"voxel axes i and j are not orthogonal"),
    (np.diag([1.0, float("nan"), 2.0, 1.0]), r"singular or not finite \(voxel axis j has length nan"),
    (np.array([[1.0, 0, 0, float("nan")], [0, 1, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]]), r"the origin is not finite"),
])
def test_a_nibabel_image_with_a_singular_or_nan_affine_is_refused(tmp_path, affine, message):
    nib = pytest.importorskip("nibabel")
    labels = _sparse_voxels(tmp_path).transpose(2, 1, 0)
    image = nib.Nifti1Image(labels, np.eye(4))
    image._affine = affine  # what nibabel gives for a file whose sform is singular or NaN
    with pytest.raises(isoloft.InputError, match=message):
        isoloft.reconstruct(image)


def test_int32_labels_2_24_and_2_24_plus_1_stay_apart():
    v = np.zeros((5, 24, 24), np.int32)
    v[1:4, 4:10, 4:10] = 2 ** 24
    v[1:4, 14:20, 14:20] = 2 ** 24 + 1
    res = isoloft.reconstruct(DuckImage(v, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1, 0, 0, 0, 1, 0, 0, 0, 1)))
    assert sorted(o.label for o in res.objects) == [2 ** 24, 2 ** 24 + 1]
    with pytest.raises(isoloft.InputError, match=r"value 4294967552 is beyond 32-bit integers"):
        isoloft.reconstruct(DuckImage(v.astype(np.int64) * 256, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0),
                                      (1, 0, 0, 0, 1, 0, 0, 0, 1)))


@pytest.mark.parametrize("kwargs, message", [
    ({"threads": 2 ** 40}, r"threads: 1099511627776 is out of range \(1 \.\. 2147483647\)"),
    ({"threads": "4"}, r"threads: expected an integer, got '4'"),
    ({"labels": [-1]}, r"labels: -1 is out of range \(1 \.\. 4294967295\)"),
    ({"labels": [2 ** 40]}, r"labels: 1099511627776 is out of range"),
    ({"labels": 3}, r"labels: expected a list of integer labels, got 3"),
    ({"max_files": 2 ** 70}, r"max_files: 1180591620717411303424 is out of range"),
    ({"progress": 5}, r"progress: expected a callable \(called with a Progress\), got 5"),
    ({"report": 5}, r"report: expected a path"),
    ({"volume": "a\0b.nrrd"}, r"volume: the path holds a NUL byte"),
    ({"z_spacing": "8"}, r"z_spacing: expected a number, got '8'"),
    ({"z_spacing": float("inf")}, r"z_spacing: must be finite"),
    ({"slice_z": 3}, r"slice_z: expected a list of numbers"),
    ({"method": 3}, r"method: expected a string, got 3"),
])
def test_every_argument_is_checked_before_the_work_naming_it(tmp_path, kwargs, message):
    called = []
    with pytest.raises(isoloft.ParamError, match=message):
        isoloft.reconstruct(ball_masks(), **{"z_spacing": BALL_Z_SPACING, "report": tmp_path / "r.json",
                                             "progress": called.append, **kwargs})
    assert not called, "the work started"
    assert not (tmp_path / "r.json").exists()


def test_image_shape_is_checked_naming_it():
    square = [[np.array([[2.0, 2], [6, 2], [6, 6], [2, 6]])]] * 3
    for shape, message in [((2 ** 40, 8), r"image_shape: 1099511627776 is out of range \(1 \.\. 1048576\)"),
                           ((8,), r"image_shape: expected \(height, width\), got \(8,\)"),
                           ((8.5, 8), r"image_shape: expected an integer, got 8.5")]:
        with pytest.raises(isoloft.ParamError, match=message):
            isoloft.reconstruct(square, input="polylines", image_shape=shape)


def test_read_checks_its_arguments_naming_them(tmp_path):
    with pytest.raises(isoloft.ParamError, match=r"path: expected a path, a list of paths or an image, got int"):
        isoloft.read(5)
    with pytest.raises(isoloft.ParamError, match=r"voxel_size: expected a number, got 'x'"):
        isoloft.read(tmp_path / "x.dcm", voxel_size="x")
    with pytest.raises(isoloft.ParamError, match=r"axis: expected a string, got 1"):
        isoloft.read(tmp_path / "x.nii", axis=1)
