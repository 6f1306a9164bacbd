"""isoloft: smooth closed surfaces from sparse parallel planar contours
(Marker, Braude, Museth & Breen 2006), on numpy arrays.

    import isoloft
    stack = isoloft.synth("torus", z_spacing=8)           # analytic test stack
    res = isoloft.reconstruct(stack)                     # or an (n, h, w) array, or isoloft.read(path)
    obj = res.objects[0]                                 # .label, .vertices (N, 3), .faces (M, 3)
    print(isoloft.evaluate(obj, stack)["in_range"]["mean_distance_px"], res.report["timings_s"]["total"])

Every reconstruction parameter goes by the name `isoloft reconstruct
--print-params` shows (nested ones as dicts: mpu={"n_min": 100}); the
library's parameter tables check them, so a bad key or value raises
ParamError naming it. Errors: InputError and ParamError (both ValueError
subclasses) for bad input and parameters, Error for the rest.
"""

import os as _os

from . import _isoloft
from ._isoloft import (Error, Input, InputError, Object, ParamError, Result, default_params,
                       describe_params, shapes)

__version__ = _isoloft.__version__
__all__ = ["reconstruct", "read", "synth", "evaluate", "default_params", "describe_params", "shapes",
           "Input", "Result", "Object", "Error", "InputError", "ParamError"]

_KINDS = ("contours", "masks", "labels", "polylines")


def _paths(path):
    if isinstance(path, (str, bytes, _os.PathLike)):
        return [_os.fsdecode(path)]
    return [_os.fsdecode(p) for p in path]


def _path_or_empty(path):
    return "" if path is None else _os.fsdecode(path)


def read(path, *, input=None, z_spacing=None, slice_z=None, pixel_size=None, axis=None, roi=None,
         voxel_size=None, space=None, max_memory="4G"):
    """Reads what `isoloft reconstruct` reads, as an Input for reconstruct().

    path: a directory of PNG slices or a list of PNG files (input: contours,
    masks or labels; z_spacing or slice_z; pixel_size), a polyline text file,
    a label volume (.nii .nii.gz .nrrd .nhdr .mha .mhd; input labels|masks,
    axis i|j|k, space lps|ras) or a DICOM RT Structure Set (roi: a name or
    number, or a list of them; voxel_size in mm, space). Options the input cannot use are
    a ParamError naming them. max_memory: the budget checked from the image
    headers before decoding ("4G", "512M", bytes; 0 = no limit).
    """
    rois = [] if roi is None else [str(roi)] if isinstance(roi, (str, int)) else [str(r) for r in roi]
    return _isoloft._read(_paths(path), input or "", z_spacing, None if slice_z is None else list(slice_z),
                          pixel_size, axis or "", rois, voxel_size, space or "", str(max_memory))


def synth(shape, *, size=128, z_spacing=8.0, kind="contours"):
    """An analytic shape (see shapes()) cut into a size x size slice stack,
    z_spacing pixels apart, as contours, masks or polylines; `.truth` is the
    shape (what evaluate() compares against), as `isoloft synth` writes it."""
    return _isoloft._synth(shape, size, z_spacing, kind)


def reconstruct(slices, *, z_spacing=1.0, slice_z=None, pixel_size=1.0, input="contours", method=None,
                labels=None, threads=None, progress=None, image_shape=None, allow_empty=False, volume=None,
                labelmap=None, dump_stages=None, rtstruct=None, volumes=None, report=None, max_memory="4G",
                max_output="4G", **params):
    """Closed surfaces from a slice stack; returns a Result (.objects, .report, .save()).

    slices: an (n, h, w) numpy array or a list of 2D arrays (bool, uint8,
    uint16: white is above half range; other integers: any label values),
    slice k at z = k * z_spacing (or slice_z[k]), in pixels; input is
    contours, masks or labels. input="polylines": slices is a list per slice of
    (k, 2) x, y point arrays on a grid of image_shape=(h, w). An Input (read(),
    synth()) or a path (read with the options given here) works too.
    method: isoloft (default), marker2006 or levin; labels: only these (labels input);
    threads: worker threads (default: all cores); progress(stage, done, total)
    is called as the work goes (raise in it to stop); allow_empty: return a
    surface with no triangles instead of raising on it. Files written with
    the run, all or none, as the CLI's flags of the same names: volume
    (OUT.nrrd, the signed distance volume per object), labelmap (a volume
    input's dense label map, .nii.gz/.nii/.nrrd/.mha), dump_stages (a
    directory: marker2006's per-slice fields), rtstruct (an RT Structure Set
    input's surfaces back as OUT.dcm, cut at its contour planes), volumes
    (the volume table, .csv or .json; .report["volumes"] always has it),
    report (the JSON of .report).
    max_memory, max_output: the work budget ("4G", "512M", bytes; 0 = no
    limit), checked before the work. **params: reconstruction parameters by
    their --print-params names.
    """
    if method is not None:
        params["method"] = method
    if isinstance(slices, Input):
        given = [name for name, value, default in (("z_spacing", z_spacing, 1.0), ("slice_z", slice_z, None),
                                                   ("pixel_size", pixel_size, 1.0), ("input", input, "contours"),
                                                   ("image_shape", image_shape, None)) if value != default]
        if given:
            raise ParamError(f"{given[0]}: the Input already holds its slices and geometry (give it to isoloft.read)")
        stack = slices
    elif isinstance(slices, (str, bytes, _os.PathLike)):
        options = {"z_spacing": z_spacing if z_spacing != 1.0 else None, "slice_z": slice_z,
                   "pixel_size": pixel_size if pixel_size != 1.0 else None,
                   "input": input if input != "contours" else None, "max_memory": max_memory}
        stack = read(slices, **options)
    else:
        if input not in _KINDS:
            raise ParamError(f"input: unknown value '{input}' (expected contours, masks, labels or polylines)")
        z = z_spacing if slice_z is None or z_spacing != 1.0 else None  # both given: the library's error
        stack = _isoloft._from_arrays(slices, input, z,
                                      None if slice_z is None else [float(z) for z in slice_z], pixel_size,
                                      None if image_shape is None else tuple(int(n) for n in image_shape))
    if labels is not None:
        labels = [int(l) for l in labels]
    return _isoloft._reconstruct(stack, params, labels or [], threads, progress, bool(allow_empty),
                                 _path_or_empty(volume), _path_or_empty(labelmap), _path_or_empty(dump_stages),
                                 _path_or_empty(rtstruct), _path_or_empty(volumes), _path_or_empty(report),
                                 str(max_memory), str(max_output))


def evaluate(mesh, truth, *, pixel_size=1.0):
    """Distances from a mesh to the analytic truth (as `isoloft eval --truth`'s
    "mesh_to_truth"), in pixels: in the slice range and in the end caps.

    mesh: an Object from reconstruct(), or anything with .vertices and .faces
    (or a (vertices, faces) pair) in pixels times pixel_size. truth: an Input
    from synth(), its .truth dict, or the path of a shape.json.
    """
    return _isoloft._evaluate(mesh, truth, pixel_size)
