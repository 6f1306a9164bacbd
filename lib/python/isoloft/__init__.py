"""isoloft: smooth closed surfaces from sparse parallel planar contours
(Marker, Braude, Museth & Breen 2006), on numpy arrays, medical images and
files.

    import isoloft
    stack = isoloft.synth("torus", z_spacing=8)          # analytic test stack
    res = isoloft.reconstruct(stack)                     # or an (n, h, w) array, a nibabel image, a path
    obj = res.objects[0]                                 # .label, .vertices (N, 3), .faces (M, 3)
    print(isoloft.evaluate(obj, stack)["in_range"]["mean_distance_px"], res.report["timings_s"]["total"])

Every reconstruction parameter goes by the name `isoloft reconstruct
--print-params` shows (nested ones as dicts: mpu={"n_min": 100}); the
library's parameter tables check them, so a bad key or value raises
ParamError naming it. Errors: InputError and ParamError (both ValueError
subclasses) for bad input and parameters, Error for the rest.
"""

import os as _os

import numpy as _np

from . import _isoloft
from ._isoloft import (Error, Input, InputError, Object, ParamError, Progress, Result, default_params,
                       describe_params, shapes)

__version__ = _isoloft.__version__
__all__ = ["reconstruct", "read", "synth", "evaluate", "batch", "progress_bars", "default_params",
           "describe_params", "shapes", "Input", "Result", "Object", "Progress", "Error", "InputError",
           "ParamError"]

_KINDS = ("contours", "masks", "labels", "polylines")
_BUDGET = "4G"  # the CLI's --max-memory and --max-output default
_MAX_FILES = _isoloft._DEFAULT_MAX_FILES  # the CLI's --max-files default


# Argument checks: every argument refused before the work with isoloft's own
# error naming it (not a TypeError or OverflowError from inside the package).
_MAX_LABEL = 2 ** 32 - 1      # labels are uint32 (0 is the background)
_MAX_COUNT = 2 ** 63 - 1      # max_files: the library's long
_MAX_THREADS = 2 ** 31 - 1    # threads: the library's int (TBB caps it at its arena anyway)
_MAX_GRID = 1 << 20           # image_shape sides: the polyline file reader's largest 'size'


def _integer(name, value, lo, hi):
    import numbers
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ParamError(f"{name}: expected an integer, got {value!r}")
    value = int(value)
    if not lo <= value <= hi:
        raise ParamError(f"{name}: {value} is out of range ({lo} .. {hi})")
    return value


def _number(name, value):
    """A finite real number (None passes through)."""
    import numbers
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParamError(f"{name}: expected a number, got {value!r}")
    value = float(value)
    if not _np.isfinite(value):
        raise ParamError(f"{name}: must be finite, got {value}")
    return value


def _text(name, value):
    """An option spelled as text (None passes through as "")."""
    if value is None:
        return ""
    if not isinstance(value, str):
        raise ParamError(f"{name}: expected a string, got {value!r}")
    return value


def _check_path(name, value):
    if value is None:
        return ""
    if not _is_path(value):
        raise ParamError(f"{name}: expected a path (str or os.PathLike), got {value!r}")
    path = _os.fsdecode(value)
    if "\0" in path:
        raise ParamError(f"{name}: the path holds a NUL byte")
    return path


def _labels(labels):
    if labels is None:
        return []
    if _is_path(labels) or not hasattr(labels, "__iter__"):
        raise ParamError(f"labels: expected a list of integer labels, got {labels!r}")
    return [_integer("labels", l, 1, _MAX_LABEL) for l in labels]


def _image_shape(shape):
    if shape is None:
        return None
    try:
        h, w = shape
    except (TypeError, ValueError):
        raise ParamError(f"image_shape: expected (height, width), got {shape!r}") from None
    return (_integer("image_shape", h, 1, _MAX_GRID), _integer("image_shape", w, 1, _MAX_GRID))


def _vector(img, method, size):
    """img.method() as `size` floats, or InputError naming the image and the method."""
    where = f"slices ({type(img).__name__})"
    try:
        v = _np.asarray(getattr(img, method)(), dtype=float).ravel()
    except (TypeError, ValueError) as e:
        raise InputError(f"{where}: {method}() is not numbers ({e})") from None
    if v.size != size:
        raise InputError(f"{where}: {method}() gives {v.size} values, expected {size}")
    return v


def _is_path(x):
    return isinstance(x, (str, bytes, _os.PathLike))


def _paths(path):
    if _is_path(path):
        return [_os.fsdecode(path)]
    return [_os.fsdecode(p) for p in path]


def _rois(roi):
    return [] if roi is None else [str(roi)] if isinstance(roi, (str, int)) else [str(r) for r in roi]


def _is_image(x):
    """A medical image object: nibabel's (an affine and voxel data) or SimpleITK's
    (origin, spacing, direction), duck-typed."""
    return (hasattr(x, "affine") and (hasattr(x, "dataobj") or hasattr(x, "get_fdata"))) or \
        all(hasattr(x, m) for m in ("GetOrigin", "GetSpacing", "GetDirection"))


def _image_volume(img):
    """(voxels as an (nk, nj, ni) array, spacing, origin, direction) of an
    image object, in DICOM patient space (LPS, mm), x fastest as the volume
    readers give them."""
    if hasattr(img, "affine"):  # nibabel: voxel (i, j, k) -> RAS mm by a 4x4 affine
        data = _np.asanyarray(img.dataobj) if hasattr(img, "dataobj") else _np.asanyarray(img.get_fdata())
        if data.ndim == 4 and data.shape[3] == 1:
            data = data[..., 0]
        if data.ndim != 3:
            raise InputError(f"slices ({type(img).__name__}): expected a 3D image, got {data.ndim} dimensions")
        try:
            affine = _np.asarray(img.affine, dtype=float)
        except (TypeError, ValueError) as e:
            raise InputError(f"slices ({type(img).__name__}): the affine is not numbers ({e})") from None
        if affine.shape != (4, 4):
            raise InputError(f"slices ({type(img).__name__}): the affine is {affine.shape}, expected 4 x 4")
        lps = _np.diag([-1.0, -1.0, 1.0]) @ affine[:3]
        spacing = _np.linalg.norm(lps[:, :3], axis=0)
        with _np.errstate(all="ignore"):  # a zero or NaN axis: refused by the library's geometry check, named
            return data.transpose(2, 1, 0), spacing, lps[:, 3], lps[:, :3] / spacing
    # SimpleITK: origin, spacing and direction (row-major, columns the axes) in LPS; array (k, j, i)
    data = None
    module = type(img).__module__.split(".")[0]
    if module == "SimpleITK":
        import SimpleITK  # noqa: the image's own module, already imported by its caller
        data = SimpleITK.GetArrayViewFromImage(img)
    else:
        data = _np.asarray(img)
    if data.ndim != 3:
        raise InputError(f"slices ({type(img).__name__}): expected a 3D image, got {data.ndim} dimensions")
    direction = _vector(img, "GetDirection", 9).reshape(3, 3)
    return data, _vector(img, "GetSpacing", 3), _vector(img, "GetOrigin", 3), direction


def read(path, *, input=None, z_spacing=None, slice_z=None, pixel_size=None, axis=None, roi=None,
         voxel_size=None, space=None, max_memory=_BUDGET, allow_external_data=False, label_names=None,
         method=None):
    """Reads what `isoloft reconstruct` reads, as an Input for reconstruct().

    path: a directory of PNG slices or a list of PNG files (input: contours,
    masks or labels; z_spacing or slice_z; pixel_size), a polyline text file,
    a label volume (.nii .nii.gz .nrrd .nhdr .mha .mhd; input labels|masks,
    axis i|j|k, space lps|ras) or a DICOM RT Structure Set (roi: a name or a
    number, or a list of them; voxel_size in mm, space). A nibabel or SimpleITK image
    object is read as a volume file is (its voxels and its geometry).
    Options the input cannot use are a ParamError naming them. max_memory:
    the budget checked from the image headers before decoding ("4G",
    "512M", bytes; 0 = no limit). allow_external_data: a NRRD or MetaImage
    header may name a data file outside its own folder (refused by default).
    label_names: a label volume's table of names (AAL .nii.txt, FreeSurfer
    LUT, 3D Slicer .ctbl, ITK-SNAP label descriptions), as the CLI's
    --label-names; default: such a table beside the volume file.
    method: the method the Input is for, as reconstruct()'s; with one that
    reads sections (field3d), an RT Structure Set's ROIs with contours on
    oblique planes are read as sections on their own planes (else refused).
    """
    names = "" if label_names is None else _os.fsdecode(label_names)
    if _is_image(path):
        given = [n for n, v in (("z_spacing", z_spacing), ("slice_z", slice_z), ("pixel_size", pixel_size),
                                ("roi", roi), ("voxel_size", voxel_size)) if v is not None]
        if given:
            raise ParamError(f"{given[0]}: an image carries its own voxel geometry")
        data, spacing, origin, direction = _image_volume(path)
        integer = data.dtype.kind in "biu"
        # Integers as they are (labels beyond 2^24 stay apart), others as float32.
        return _isoloft._from_volume(_np.ascontiguousarray(data) if integer else
                                     _np.ascontiguousarray(data, dtype=_np.float32), list(map(float, spacing)),
                                     list(map(float, origin)), _np.ascontiguousarray(direction, dtype=float),
                                     integer, f"slices ({type(path).__name__})", _text("input", input),
                                     _text("axis", axis), _text("space", space), names)
    if not _is_path(path) and not (hasattr(path, "__iter__") and all(_is_path(p) for p in path)):
        raise ParamError(f"path: expected a path, a list of paths or an image, got {type(path).__name__}")
    return _isoloft._read(_paths(path), _text("input", input), _number("z_spacing", z_spacing),
                          None if slice_z is None else [_number("slice_z", z) for z in slice_z],
                          _number("pixel_size", pixel_size), _text("axis", axis), _rois(roi),
                          _number("voxel_size", voxel_size), _text("space", space), str(max_memory),
                          bool(allow_external_data), names, _text("method", method) or "")


def synth(shape, *, size=128, z_spacing=8.0, kind="contours"):
    """An analytic shape (see shapes()) cut into a size x size slice stack,
    z_spacing pixels apart, as contours, masks or polylines; `.truth` is the
    shape (what evaluate() compares against), as `isoloft synth` writes it."""
    return _isoloft._synth(shape, size, z_spacing, kind)


def _is_sections(x):
    """A list of section dicts (reconstruct()'s sections in any orientation)."""
    import collections.abc
    return isinstance(x, (list, tuple)) and len(x) > 0 and isinstance(x[0], collections.abc.Mapping)


def reconstruct(slices, *, input=None, z_spacing=None, slice_z=None, pixel_size=None, axis=None, roi=None,
                voxel_size=None, space=None, image_shape=None, method=None, labels=None, threads=None,
                progress=None, allow_empty=False, volume=None, labelmap=None, reference=None, dump_stages=None,
                rtstruct=None, rt_point_spacing=0.0, rt_min_area=0.0, rt_contours=None, volumes=None, report=None, max_memory=_BUDGET, max_output=_BUDGET, max_files=_MAX_FILES, allow_external_data=False, label_names=None, **params):
    """Closed surfaces from a slice stack; returns a Result (.objects, .report, .save()).

    slices, one of:
    - an (n, h, w) numpy array or a list of 2D arrays, slice k at
      z = k * z_spacing (or slice_z[k]) pixels, pixel_size the units of a
      pixel. input: contours (white curves), masks (filled) or labels (each
      value an object); without it, the arrays say: more than two values are
      labels; two (0 and one other, e.g. bool) are filled masks unless they
      hold only thin curves (contours); anything else is refused, naming
      `input`. binarize=True thresholds gray images at half their type's
      range first. input="polylines": a list per slice of (k, 2) x, y point
      arrays on a grid of image_shape=(h, w).
    - a nibabel or SimpleITK image, or a path (PNG slices, a polyline file, a
      NIfTI/NRRD/MetaImage volume, an RT Structure Set): read as read() reads
      it, with its options given here (input, z_spacing, slice_z,
      pixel_size, axis, roi, voxel_size, space, label_names); images and volumes keep
      their geometry: the meshes are in patient mm (LPS, or space="ras").
    - sections in any orientation: a list of dicts {origin, u, v (3 numbers
      each, world units; u, v orthonormal in-plane axes), contours: a list
      of {points (N x 2 in-plane along u, v, or N x 3 world points on the
      plane), label (default 1), hole (default False)}}; each label is one
      object, the labels one partition (touching ones share their
      boundary); the meshes are in the sections' world units. They need
      method="field3d" (as a CSL file does). A section may hold a label
      image instead of contours: {image: 2D integers (0 outside), affine:
      4 x 4, (a, b, 0, 1) of image[a, b] to the world} or {image, origin, u,
      v, pixel_size} (image[a, b] at origin + a pixel_size u + b pixel_size
      v); each label's pixels are traced to their sub-pixel boundary.
    - an Input from read() or synth().
    method: isoloft (default), marker2006 or levin; labels: only these;
    threads: worker threads (default: all cores); progress(p) is called with
    a Progress (.label, .roi, .stage, .done, .total: done only grows for an
    object; see progress_bars()) as the work goes (raise in it to stop);
    allow_empty: return a surface with no triangles instead of raising on it.
    Files written with the run, all or none, as the CLI's flags of the same
    names: volume (OUT.nrrd, the signed distance volume per object),
    labelmap (a volume's dense label map, .nii.gz/.nii/.nrrd/.mha; with
    reference, a CT series folder or a volume file, on that grid: one label
    per ROI number or label, the smallest object on top where they overlap),
    dump_stages (a directory: per-slice fields), rtstruct (an RT Structure
    Set input's surfaces back as OUT.dcm, cut at its contour planes; with
    rt_point_spacing mm between points, 0 = as drawn; rt_min_area mm^2, lost
    drawn contours under it dropped; rt_contours, the per-contour report as
    .csv; .report["rtstruct_contours"] always has it), volumes
    (the volume table, .csv or .json; .report["volumes"] always has it),
    report (the JSON of .report). max_memory, max_output: the work budget ("4G", "512M", bytes;
    0 = no limit), checked before the work; max_files: the most files the run
    writes (0 = no limit). allow_external_data: as for read(). **params: reconstruction
    parameters by their --print-params names; one the run would never read
    (another method's, or one the input cannot use) is a ParamError naming
    it, as the CLI refuses its flag.
    """
    # Every argument checked before any work, named in the error.
    labels = _labels(labels)
    if threads is not None:
        threads = _integer("threads", threads, 1, _MAX_THREADS)
    if progress is not None and not callable(progress):
        raise ParamError(f"progress: expected a callable (called with a Progress), got {progress!r}")
    max_files = _integer("max_files", max_files, 0, _MAX_COUNT)
    image_shape = _image_shape(image_shape)
    outputs = {n: _check_path(n, v) for n, v in (("volume", volume), ("labelmap", labelmap), ("reference", reference),
                                                  ("dump_stages", dump_stages), ("rtstruct", rtstruct),
                                                  ("rt_contours", rt_contours), ("volumes", volumes), ("report", report))}
    rt_point_spacing, rt_min_area = _number("rt_point_spacing", rt_point_spacing), _number("rt_min_area", rt_min_area)
    z_spacing, pixel_size, voxel_size = (_number("z_spacing", z_spacing), _number("pixel_size", pixel_size),
                                         _number("voxel_size", voxel_size))
    if slice_z is not None:
        if _is_path(slice_z) or not hasattr(slice_z, "__iter__"):
            raise ParamError(f"slice_z: expected a list of numbers, got {slice_z!r}")
        slice_z = [_number("slice_z", z) for z in slice_z]
    for n, v in (("input", input), ("axis", axis), ("space", space), ("method", method)):
        _text(n, v)
    if method is not None:
        params["method"] = method
    read_options = {"input": input, "z_spacing": z_spacing, "slice_z": slice_z, "pixel_size": pixel_size,
                    "axis": axis, "roi": roi, "voxel_size": voxel_size, "space": space, "label_names": label_names}
    external = {"allow_external_data": True} if allow_external_data else {}
    if isinstance(slices, Input):
        given = [n for n, v in read_options.items() if v is not None] + (["image_shape"] if image_shape else [])
        if given:
            raise ParamError(f"{given[0]}: the Input already holds its slices and geometry (give it to isoloft.read)")
        stack = slices
    elif _is_sections(slices):
        given = [n for n, v in read_options.items() if v is not None] + (["image_shape"] if image_shape else [])
        if given:
            raise ParamError(f"{given[0]}: sections carry their own poses and units (origin, u, v)")
        stack = _isoloft._from_sections(slices)
    elif _is_path(slices) or _is_image(slices):
        if image_shape is not None:
            raise ParamError("image_shape: only with input='polylines' arrays")
        stack = read(slices, max_memory=max_memory, method=method, **read_options, **external)
    else:
        given = [n for n in ("axis", "roi", "voxel_size", "space", "label_names") if read_options[n] is not None]
        if given:
            raise ParamError(f"{given[0]}: only with a volume, an image or an RT Structure Set, not with arrays")
        if input is not None and input not in _KINDS:
            raise ParamError(f"input: unknown value '{input}' (expected contours, masks, labels or polylines)")
        stack = _isoloft._from_arrays(slices, input or "", z_spacing,
                                      None if slice_z is None else [float(z) for z in slice_z],
                                      1.0 if pixel_size is None else pixel_size,
                                      image_shape, bool(params.get("binarize", False)))
    return _isoloft._reconstruct(stack, params, labels, threads, progress, bool(allow_empty),
                                 outputs["volume"], outputs["labelmap"], outputs["dump_stages"], outputs["rtstruct"],
                                 rt_point_spacing, rt_min_area, outputs["rt_contours"],
                                 outputs["volumes"], outputs["report"], str(max_memory), str(max_output), max_files,
                                 outputs["reference"])


def evaluate(mesh, truth, *, pixel_size=1.0):
    """Distances from a mesh to the analytic truth (as `isoloft eval --truth`'s
    "mesh_to_truth"), in pixels: in the slice range and in the end caps.

    mesh: an Object from reconstruct(), or anything with .vertices and .faces
    (or a (vertices, faces) pair) in pixels times pixel_size. truth: an Input
    from synth(), its .truth dict, or the path of a shape.json.
    """
    return _isoloft._evaluate(mesh, truth, pixel_size)


def progress_bars(**tqdm_options):
    """A progress callback drawing one tqdm bar per object (tqdm must be
    installed): reconstruct(..., progress=isoloft.progress_bars())."""
    from tqdm.auto import tqdm

    bars = {}

    def update(p):
        key = (p.roi, p.label)
        bar = bars.get(key)
        if bar is None:
            name = p.roi or (f"label {p.label}" if p.label else "labels" if p.stage == "contour" else "object")
            bar = bars[key] = tqdm(total=p.total, desc=name, unit="step", **tqdm_options)
        bar.total = p.total
        bar.update(p.done - bar.n)  # done only grows per object

    return update


def batch(manifest, out, **options):
    """Runs a cohort: one `isoloft reconstruct` per manifest row on Dask
    distributed (see isoloft.cohort.batch for the options); returns the
    summary rows."""
    from .cohort import batch as run_batch
    return run_batch(manifest, out, **options)


# ---------------------------------------------------------------- conversions

def _combined(objects):
    """Vertices, faces and each face's label of several objects, concatenated."""
    vertices, faces, labels, offset = [], [], [], 0
    for i, o in enumerate(objects):
        vertices.append(o.vertices)
        faces.append(_np.asarray(o.faces, dtype=_np.int64) + offset)
        labels.append(_np.full(len(o.faces), o.label if o.label else i + 1, dtype=_np.uint32))
        offset += len(o.vertices)
    return _np.concatenate(vertices), _np.concatenate(faces), _np.concatenate(labels)


def _parts(self):
    return list(self.objects) if isinstance(self, Result) else [self]


def _to_meshio(self):
    """A meshio.Mesh: the triangles, their label as cell data "label"."""
    import meshio
    v, f, lab = _combined(_parts(self))
    return meshio.Mesh(v, [("triangle", f)], cell_data={"label": [lab]})


def _to_pyvista(self):
    """A pyvista.PolyData: the triangles, their label as cell data "label"."""
    import pyvista
    v, f, lab = _combined(_parts(self))
    mesh = pyvista.PolyData(v, _np.hstack([_np.full((len(f), 1), 3, dtype=_np.int64), f]).ravel())
    mesh.cell_data["label"] = lab
    return mesh


def _to_trimesh(self):
    """A trimesh.Trimesh (not merged or repaired), the label as face attribute "label"."""
    import trimesh
    v, f, lab = _combined(_parts(self))
    return trimesh.Trimesh(vertices=v, faces=f, face_attributes={"label": lab}, process=False)


for _cls in (Object, Result):
    _cls.to_meshio = _to_meshio
    _cls.to_pyvista = _to_pyvista
    _cls.to_trimesh = _to_trimesh
del _cls
