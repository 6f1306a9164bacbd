#!/usr/bin/env python3
"""The issue-27 cases (hostile and malformed files), run against one or two
isoloft CLIs (after / before) as bad_input_audit.py runs the issue-17 ones:
fresh directory, `timeout`, the 8 GB address-space limit; recorded: exit
status, wall seconds, peak RSS (MiB), the first error or warning line (or, for
a finished run, the files it wrote), and the files or folders left behind.
Plus the race: two runs to one -o, ten times, counting mixed output sets.

Needs Debian's python3 (pydicom for the RT Structure Set cases).

usage: hostile_input_audit.py OUT.md CLI [CLI_BEFORE] [--timeout S] [--only NAME,...] [--races N]
"""
import gzip
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bad_input_audit as audit  # noqa: E402

RTSS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "rtstruct", "rtss.dcm")


# ----------------------------------------------------------------- files

def nifti1(path, dims, values, dtype="B", origin=(0.0, 0.0, 0.0), level=6):
    """A NIfTI-1 .nii(.gz): dims (nx, ny, nz), values in x-fastest order, sform = 1 mm voxels at origin (RAS)."""
    codes = {"B": (2, 8), "H": (512, 16), "i": (8, 32)}
    code, bits = codes[dtype]
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, dims[0], dims[1], dims[2], 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, code, bits)
    struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352.0)
    struct.pack_into("<f", h, 112, 1.0)  # scl_slope
    struct.pack_into("<h", h, 254, 1)  # sform_code
    for r, row in enumerate(((1, 0, 0, origin[0]), (0, 1, 0, origin[1]), (0, 0, 1, origin[2]))):
        struct.pack_into("<4f", h, 280 + 16 * r, *row)
    h[344:348] = b"n+1\0"
    data = bytes(h) + b"\0" * 4 + struct.pack("<%d%s" % (len(values), dtype), *values)
    if path.endswith(".gz"):
        data = gzip.compress(data, compresslevel=level)
    with open(path, "wb") as f:
        f.write(data)
    return path


def two_labels(n=40, nz=13, every=3, a=3, b=7):
    """Label a (a ball) and b (a box) on every `every`-th axial slice of an n x n x nz volume."""
    v = [0] * (n * n * nz)
    for k in range(0, nz, every):
        for j in range(n):
            for i in range(n):
                if math.hypot(i - n * 0.33, j - n / 2) < n * 0.25 - abs(k - nz / 2) / 2:
                    v[(k * n + j) * n + i] = a
                elif n * 0.7 < i < n * 0.9 and n * 0.3 < j < n * 0.7 and 0 < k < nz - 1:
                    v[(k * n + j) * n + i] = b
    return v


def many_labels_side(count):
    """The side of the square slices that hold `count` labels at a 4 px pitch."""
    return 4 * math.isqrt(count - 1) + 4


def many_labels(count):
    """`count` labels as 2 x 2 px squares at a 4 px pitch on slices 0 and 2 of a side x side x 3 volume (uint16)."""
    side = many_labels_side(count)
    v = [0] * (side * side * 3)
    per_row = side // 4
    for lab in range(1, count + 1):
        y, x = divmod(lab - 1, per_row)
        for k in (0, 2):
            for dy in range(2):
                for dx in range(2):
                    v[(k * side + 4 * y + dy) * side + 4 * x + dx] = lab
    return v


def write(d, name, data, mode="wb"):
    p = os.path.join(d, name)
    os.makedirs(os.path.dirname(p), exist_ok=True)
    with open(p, mode) as f:
        f.write(data)
    return p


def nrrd_header(sizes, encoding, extra=b"", typ=b"uchar"):
    return (b"NRRD0004\ntype: " + typ + b"\ndimension: 3\nsizes: %d %d %d\nencoding: " % sizes + encoding + b"\n"
            + extra)


def mhd_header(sizes, data_file, extra=b""):
    return (b"ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\nElementType = MET_UCHAR\n" % sizes + extra
            + b"ElementDataFile = " + data_file + b"\n")


def rtss_variant(d, edit):
    """rtss.dcm edited by edit(ds) (pydicom), saved in d."""
    import pydicom
    ds = pydicom.dcmread(RTSS)
    edit(ds)
    p = os.path.join(d, "rt.dcm")
    ds.save_as(p)
    return p


def small_rois(ds, keep):
    """Keeps only the ROIs named in `keep` (in that order), contours and all."""
    numbers = {str(r.ROIName): int(r.ROINumber) for r in ds.StructureSetROISequence}
    wanted = [numbers[n] for n in keep]
    ds.StructureSetROISequence = [r for r in ds.StructureSetROISequence if int(r.ROINumber) in wanted]
    ds.ROIContourSequence = [c for c in ds.ROIContourSequence if int(c.ReferencedROINumber) in wanted]
    return ds


# ----------------------------------------------------------------- cases

def cases():
    """name -> (setup(d, cli) -> arguments after "reconstruct", options for run_case)."""
    c = {}
    quiet, loud = {}, {"quiet": False}
    n = 40
    labels = two_labels(n)

    def vol(name="v.nii.gz", **kw):
        return lambda d, cli: [nifti1(os.path.join(d, name), (n, n, 13), labels, **kw), "--method", "levin"]

    # Hangs.
    c["NRRD zrl of 2100 2100 1000 in 4 bytes"] = (
        lambda d, cli: [write(d, "z.nrrd", nrrd_header((2100, 2100, 1000), b"zrl") + b"\n\x01\x02\x03\x04")], quiet)

    def fifo(d, cli):
        audit.png(os.path.join(d, "a.png"), 8, 8)
        os.mkfifo(os.path.join(d, "f.png"))
        return [os.path.join(d, "a.png"), os.path.join(d, "f.png")]
    c["a FIFO as a slice"] = (fifo, quiet)
    c["65535 labels (NIfTI 2x2 px each)"] = (
        lambda d, cli: [nifti1(os.path.join(d, "many.nii.gz"), (many_labels_side(65535),) * 2 + (3,), many_labels(65535),
                               "H"), "--method",
                        "levin"], quiet)

    # Reads outside what the user named.
    def outside_nrrd(d, cli):
        return [write(d, "in/sub/x.nhdr", nrrd_header((8, 8, 2), b"raw", b"data file: ../../../../../../../../etc/passwd\n")),
                "--method", "levin"]
    c["NRRD data file ../../../../etc/passwd"] = (outside_nrrd, quiet)
    c["MetaImage ElementDataFile /etc/passwd"] = (
        lambda d, cli: [write(d, "x.mhd", mhd_header((8, 8, 2), b"/etc/passwd")), "--method", "levin"], quiet)

    # Silent wrong results.
    def flipped(d, cli):
        p = nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), labels, level=0)  # stored blocks: a flip still inflates
        b = bytearray(open(p, "rb").read())
        b[b.index(bytes([3, 3, 3, 3]), 400) + 1] ^= 0x10  # one voxel of label 3 becomes 19
        open(p, "wb").write(bytes(b))
        return [p, "--method", "levin"]
    c[".nii.gz with one flipped byte"] = (flipped, quiet)
    big = {0: 0, 3: 16777216, 7: 16777217}
    c["int32 labels 16777216 and 16777217"] = (
        lambda d, cli: [nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), [big[x] for x in labels], "i"),
                        "--method", "levin"], quiet)

    def nifti2(d, cli):
        h = bytearray(544)
        struct.pack_into("<i", h, 0, 540)
        h[4:12] = b"n+2\0\r\n\x1a\n"
        struct.pack_into("<hh", h, 12, 2, 8)
        struct.pack_into("<8q", h, 16, 3, (1 << 32) + 64, 4, 4, 1, 1, 1, 1)
        struct.pack_into("<8d", h, 104, *([1.0] * 8))
        struct.pack_into("<q", h, 168, 544)
        body = bytearray(64 * 16)
        for k in range(4):
            for j in range(1, 3):
                for i in range(20, 40):
                    body[(k * 4 + j) * 64 + i] = 3
        return [write(d, "n2.nii", bytes(h) + bytes(body)), "--method", "levin"]
    c["NIfTI-2 dim[1] = 2^32 + 64"] = (nifti2, quiet)
    c["NRRD zrl data that run short"] = (
        lambda d, cli: [write(d, "s.nrrd", nrrd_header((8, 8, 2), b"zrl") + b"\n\x00\x3f\x01"), "--method", "levin"],
        quiet)

    def ascii_mha(d, cli):
        text = b" ".join(b"%d" % x for x in labels) + b"\n"
        return [write(d, "a.mha", mhd_header((n, n, 13), b"LOCAL", b"BinaryData = False\n") + text), "--method", "levin"]
    c["MetaImage BinaryData = False (ASCII voxels)"] = (ascii_mha, quiet)
    c["MetaImage header line after ElementDataFile = LOCAL"] = (
        lambda d, cli: [write(d, "l.mha", mhd_header((n, n, 13), b"LOCAL") + b"ElementSpacing = 1 1 2\n" + bytes(labels)),
                        "--method", "levin"], quiet)

    def stray(d, cli):
        v = list(labels)
        v[(4 * n + n // 2) * n + int(n * 0.8)] = 7  # one voxel of label 7 on slice k = 4
        return [nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), v), "--method", "levin"]
    c["one stray voxel of another label"] = (stray, loud)

    def other_axis(d, cli):
        v = list(labels)
        for k in range(13):  # label 9 drawn on every 4th coronal (j) slice
            for j in range(2, n - 2, 4):
                for i in range(4, 12):
                    if 2 < k < 11:
                        v[(k * n + j) * n + i] = 9
        return [nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), v), "--method", "levin"]
    c["a label drawn along another axis"] = (other_axis, loud)
    c["--axis j on k-annotated labels"] = (lambda d, cli: vol()(d, cli) + ["--axis", "j"], loud)
    c["x = 1e9 mm"] = (lambda d, cli: [nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), labels, origin=(1e9, 0, 0)),
                                       "--method", "levin"], loud)
    c["--max-memory 200M with 16384 labels"] = (
        lambda d, cli: [nifti1(os.path.join(d, "many.nii.gz"), (many_labels_side(16384),) * 2 + (3,), many_labels(16384), "H"),
                        "--max-memory", "200M", "--method", "levin"], quiet)

    def same_file(d, cli):
        os.makedirs(os.path.join(d, "out"))
        return vol()(d, cli) + ["--input", "masks", "--volume", os.path.join(d, "out", "x.nrrd"), "--labelmap",
                                os.path.join(d, ".", "out", "x.nrrd")]
    c["--volume out/x.nrrd --labelmap ./out/x.nrrd"] = (same_file, quiet)

    def failed_dirs(d, cli):
        os.makedirs(os.path.join(d, "m.ply"))  # the mesh's path is a folder: the run fails at its end
        return vol()(d, cli) + ["--volume", os.path.join(d, "new", "sub", "v.nrrd")]
    c["a failed run's folders"] = (failed_dirs, quiet)

    # Errors that say why.
    c["NRRD 'sizes: 4 four 2' (teem's reason)"] = (
        lambda d, cli: [write(d, "b.nrrd", b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 four 2\nencoding: raw\n\n")],
        quiet)
    c["1 KB gzip NRRD of 2000^3 with --max-memory 100M"] = (
        lambda d, cli: [write(d, "g.nrrd", nrrd_header((2000, 2000, 2000), b"gzip") + b"\n" + gzip.compress(b"\0" * 1000)),
                        "--max-memory", "100M"], quiet)

    def bad_crc(d, cli):
        p = nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), labels)
        b = bytearray(open(p, "rb").read())
        b[-6] ^= 0x10
        open(p, "wb").write(bytes(b))
        return [p]
    c["NIfTI .gz with a bad CRC"] = (bad_crc, quiet)

    def no_img(d, cli):
        p = nifti1(os.path.join(d, "v.nii"), (n, n, 13), labels)
        h = bytearray(open(p, "rb").read()[:348])
        h[344:348] = b"ni1\0"
        os.remove(p)
        return [write(d, "v.hdr", bytes(h))]
    c["a .hdr without its .img"] = (no_img, quiet)

    def dir_data(d, cli):
        os.makedirs(os.path.join(d, "data.raw"))
        return [write(d, "x.mhd", mhd_header((8, 8, 2), b"data.raw"))]
    c["a folder as MetaImage data file"] = (dir_data, quiet)
    def spaced(d, cli):
        write(d, "my data.raw", bytes(labels))
        return [write(d, "x.mhd", mhd_header((n, n, 13), b"my data.raw")), "--method", "levin"]
    c["MetaImage data file 'my data.raw'"] = (spaced, quiet)

    def collide(d, cli):
        def edit(ds):
            small_rois(ds, ["Borders", "Nodes", "Scar", "Tumor Bed"])
            for r, name in zip(ds.StructureSetROISequence, ["A/B", "A_B", "A B", ""]):
                r.ROIName = name
        return [rtss_variant(d, edit), "--method", "levin", "--voxel-size", "2"]
    c["ROI names A/B A_B 'A B' '' (one file name)"] = (collide, quiet)

    def zero_area(d, cli):
        def edit(ds):
            small_rois(ds, ["Scar"])
            for ct in ds.ROIContourSequence[0].ContourSequence:  # every contour collinear: no area
                z = float(ct.ContourData[2])
                ct.ContourData = [0, 0, z, 10, 10, z, 20, 20, z]
                ct.NumberOfContourPoints = 3
        return [rtss_variant(d, edit), "--roi", "Scar", "--method", "levin"]
    c["RT contours of zero net area"] = (zero_area, loud)

    def unlisted(d, cli):
        def edit(ds):
            small_rois(ds, ["Scar", "Nodes"])
            ds.StructureSetROISequence = [r for r in ds.StructureSetROISequence if str(r.ROIName) != "Nodes"]
        return [rtss_variant(d, edit), "--method", "levin"]
    c["RT contours of an unlisted ROI"] = (unlisted, loud)

    def broken_link(d, cli):
        os.makedirs(os.path.join(d, "s"))
        ring = lambda y: bytes(255 if abs(math.hypot(x - 12, y - 12) - 6) < 0.7 else 0 for x in range(24))  # noqa: E731
        for name in ("b.png", "c.png"):
            audit.png(os.path.join(d, "s", name), 24, 24, ring)
        os.symlink(os.path.join(d, "s", "gone.png"), os.path.join(d, "s", "a.png"))
        return [os.path.join(d, "s"), "--method", "levin"]
    c["a broken .png link first in order"] = (broken_link, quiet)
    c["nan in a polyline file"] = (
        lambda d, cli: [write(d, "t.txt", b"isoloft-polylines 1\nsize 64 64\nslice 0\ncontour\n10 10\nnan 3\n20 20\n")],
        quiet)

    def long_name(d, cli):
        return [nifti1(os.path.join(d, "v.nii.gz"), (n, n, 13), labels), "--method", "levin", "--labels", "3"]
    c["a 244-byte output name"] = (long_name, {"output": "n" * 240 + ".ply"})
    return c


# ----------------------------------------------------------------- the race

def race(cli, runs, timeout):
    """Two runs to one -o, started together, `runs` times: how often the files come from both."""
    d = tempfile.mkdtemp(prefix="race_")
    try:
        a = nifti1(os.path.join(d, "a.nii.gz"), (64, 64, 13), two_labels(64))
        b = nifti1(os.path.join(d, "b.nii.gz"), (64, 64, 13), two_labels(64, a=3, b=7)[::-1])
        # Each input's files on their own, to tell whose file is whose.
        ref = {}
        for name, src in (("a", a), ("b", b)):
            out = os.path.join(d, name, "m.ply")
            subprocess.run([cli, "reconstruct", src, "-o", out, "-q"], check=True, timeout=timeout)
            ref[name] = {f: open(os.path.join(d, name, f), "rb").read() for f in os.listdir(os.path.join(d, name))}
        mixed = failed = 0
        for r in range(runs):
            out_dir = os.path.join(d, "race%d" % r)
            os.makedirs(out_dir)
            procs = [subprocess.Popen([cli, "reconstruct", src, "-o", os.path.join(out_dir, "m.ply"), "-q"],
                                      stderr=subprocess.PIPE, text=True) for src in (a, b)]
            errs = [p.communicate(timeout=timeout)[1] for p in procs]
            failed += sum(1 for p in procs if p.returncode != 0)
            whose = set()
            for f in os.listdir(out_dir):
                data = open(os.path.join(out_dir, f), "rb").read()
                whose |= {name for name in ref if ref[name].get(f) == data}
            mixed += len(whose) > 1
            last_err = next((e.strip().splitlines()[-1] for e in errs if e.strip()), "")
        return mixed, failed, last_err.replace(d + "/", "")
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ----------------------------------------------------------------- report

def cell(r):
    if r["code"] == 0 and not r["msg"]:
        wrote = sorted(f for f in r["left"] if not f.endswith("/"))
        r = dict(r, msg="wrote " + ", ".join(f[:40] for f in wrote[:3]) + (" ... (%d files)" % len(wrote) if len(wrote) > 3 else ""),
                 left=[])
    return audit.cell(r)


def main():
    ap = audit.audit_arguments()
    ap.add_argument("--races", type=int, default=10)
    a = ap.parse_args()
    all_cases = cases()
    names = [n for n in all_cases if not a.only or n in a.only.split(",")]
    rows = []
    for name in names:
        setup, opts = all_cases[name]
        clis = [("after", a.cli)] + ([("before", a.before)] if a.before else [])
        got = {}
        for which, cli in clis:
            got[which] = audit.run_case(cli, name, setup, a.timeout, **opts)
        rows.append((name, got.get("before"), got["after"]))
        print(name, "|", cell(got["before"]) if a.before else "", "|", cell(got["after"]), flush=True)
    head = "| case | " + ("before: exit | s | MiB | message | " if a.before else "") + "after: exit | s | MiB | message |\n"
    head += "|---" * (1 + (8 if a.before else 4)) + "|\n"
    body = "".join("| %s | %s%s |\n" % (n, (cell(b) + " | ") if b else "", cell(r)) for n, b, r in rows)
    if a.races and (not a.only or "race" in a.only):
        lines = []
        for which, cli in [("before", a.before), ("after", a.cli)]:
            if cli:
                mixed, failed, err = race(cli, a.races, a.timeout)
                lines.append("- %s: %d of %d races left a mixed output set; %d of %d runs failed%s\n"
                             % (which, mixed, a.races, failed, 2 * a.races, (" (" + err + ")") if err else ""))
                print(lines[-1], end="", flush=True)
        body += "\nTwo runs to one -o, started together:\n" + "".join(lines)
    audit.write_atomic(a.out, head + body)


if __name__ == "__main__":
    main()
