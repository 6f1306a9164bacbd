"""Shared helpers for the Python experiments (the paper reproduction).

Readers for the files isoloft writes (float NRRD, PLY), the polyline text
format, and running the `isoloft` CLI from a build tree. numpy only, so the
experiments run with Debian's python3-numpy / python3-matplotlib.
"""
import gzip
import json
import os
import re
import statistics
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def build_dir():
    return os.environ.get("ISOLOFT_BUILD", os.path.join(ROOT, "build"))


def isoloft_exe():
    return os.path.join(build_dir(), "isoloft")


def experiment_exe(name):
    return os.path.join(build_dir(), "experiments", name)


def run(cmd, quiet=True):
    """Runs a command; on failure prints its output and raises."""
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write(r.stdout + r.stderr)
        raise RuntimeError("command failed (%d): %s" % (r.returncode, " ".join(map(str, cmd))))
    if not quiet:
        sys.stderr.write(r.stderr)
    return r


def isoloft(*args):
    return run([isoloft_exe(), *args])


def read_json(path):
    with open(path) as f:
        return json.load(f)


def write_json(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f, indent=2)
        f.write("\n")
    os.replace(tmp, path)


def write_text(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def median(values):
    return statistics.median(values)


def read_frog(path):
    """The Whole Frog label map (MetaImage .mhd + .zraw): (labels (nz, ny, nx) uint8, spacing [x, y, z] mm)."""
    import zlib
    hdr = dict(l.split(" = ", 1) for l in open(path).read().splitlines() if " = " in l)
    nx, ny, nz = map(int, hdr["DimSize"].split())
    raw = open(os.path.join(os.path.dirname(path), hdr["ElementDataFile"]), "rb").read()
    # The header's CompressedDataSize is short of the .zraw (VTK's reader
    # then loses the last ~1.7 slices): decompress the whole stream.
    data = zlib.decompress(raw) if hdr.get("CompressedData") == "True" else raw
    spacing = [float(v) for v in hdr["ElementSpacing"].split()]
    return np.frombuffer(data, np.uint8).reshape(nz, ny, nx).copy(), spacing


def read_nrrd(path):
    """Reads a float NRRD as written by isoloft (raw or gzip). Returns
    (array indexed [z, y, x] with singleton z squeezed, header dict)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"\n\n")
    header = {}
    for line in data[:end].decode().splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        k, v = line.split(":", 1)
        header[k.strip()] = v.strip()
    if header.get("type") != "float":
        raise ValueError(path + ": only float NRRD is read here")
    sizes = [int(s) for s in header["sizes"].split()]
    body = data[end + 2:]
    if header.get("encoding") == "gzip":
        body = gzip.decompress(body)
    a = np.frombuffer(body, dtype="<f4").reshape(sizes[::-1])
    return np.squeeze(a, axis=0) if a.shape[0] == 1 else a, header


def nrrd_origin(header):
    return [float(v) for v in re.findall(r"[-+0-9.eE]+", header["space origin"])]


def read_ply(path):
    """Reads a triangle PLY written by isoloft (binary little endian or
    ascii). Returns (vertices (n, 3) float64, faces (m, 3) int64, colours or None)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode().splitlines()
    ascii = any(l.startswith("format ascii") for l in head)
    nv = nf = 0
    colours = False
    for l in head:
        t = l.split()
        if t[:2] == ["element", "vertex"]:
            nv = int(t[2])
        elif t[:2] == ["element", "face"]:
            nf = int(t[2])
        elif t[:2] == ["property", "uchar"] and t[2] == "red":
            colours = True
    if ascii:
        rows = data[end:].decode().split("\n")
        v = np.array([[float(x) for x in r.split()[:6 if colours else 3]] for r in rows[:nv]])
        fc = np.array([[int(x) for x in r.split()[1:4]] for r in rows[nv:nv + nf]], dtype=np.int64)
        col = v[:, 3:6].astype(np.uint8) if colours else None
        return v[:, :3], fc, col
    vdt = np.dtype([("p", "<f4", 3)] + ([("c", "u1", 3)] if colours else []))
    verts = np.frombuffer(data, dtype=vdt, count=nv, offset=end)
    fdt = np.dtype([("n", "u1"), ("i", "<i4", 3)])
    faces = np.frombuffer(data, dtype=fdt, count=nf, offset=end + nv * vdt.itemsize)
    if nf and not np.all(faces["n"] == 3):
        raise ValueError(path + ": only triangles are read here")
    return verts["p"].astype(np.float64), faces["i"].astype(np.int64), (verts["c"].copy() if colours else None)


def write_polylines(path, width, height, slices, pixel_size=1.0, comment=""):
    """Writes the isoloft polyline text format (README). `slices` is a list of
    (z_px, [contour (k, 2) array of x, y in pixels, ...])."""
    lines = []
    for c in comment.splitlines():
        lines.append("# " + c)
    lines += ["isoloft-polylines 1", "size %d %d" % (width, height), "pixel_size %.9g" % pixel_size]
    for z, contours in slices:
        lines.append("slice %.9g" % z)
        for c in contours:
            lines.append("contour")
            lines += ["%.4f %.4f" % (p[0], p[1]) for p in c]
    write_text(path, "\n".join(lines) + "\n")


def read_polylines(path):
    """Reads the polyline text format back: (width, height, pixel_size, slices)."""
    width = height = 0
    pixel_size = 1.0
    slices = []
    cur = None
    for raw in open(path):
        line = raw.split("#", 1)[0].strip()
        if not line or line.startswith("isoloft-polylines"):
            continue
        t = line.split()
        if t[0] == "size":
            width, height = int(t[1]), int(t[2])
        elif t[0] == "pixel_size":
            pixel_size = float(t[1])
        elif t[0] == "slice":
            slices.append((float(t[1]), []))
        elif t[0] == "contour":
            cur = []
            slices[-1][1].append(cur)
        else:
            cur.append((float(t[0]), float(t[1])))
    return width, height, pixel_size, [(z, [np.array(c) for c in cs]) for z, cs in slices]


def write_contours_csv(path, curves):
    """Contours for render_mesh --contours: x,y,z per point (in the mesh's
    units), a blank line between curves; closed curves repeat their first point."""
    out = []
    for c in curves:
        out += ["%.4f,%.4f,%.4f" % tuple(p) for p in list(c) + [c[0]]]
        out.append("")
    write_text(path, "\n".join(out) + "\n")


# Flags that only these methods read (the CLI refuses a flag that has no effect).
RASTER_METHODS = ("isoloft", "marker2006")


def method_args(args, method):
    """A run's args for `method` (None: the default, isoloft): --raster-resolution dropped where the method
    does not raster."""
    if (method or "isoloft") in RASTER_METHODS or "--raster-resolution" not in args:
        return list(args)
    i = args.index("--raster-resolution")
    return list(args[:i]) + list(args[i + 2:])
