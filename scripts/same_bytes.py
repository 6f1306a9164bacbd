#!/usr/bin/python3
# @file scripts/same_bytes.py
# @brief Same bytes before and after a change: a fixed set of cases run with two
# isoloft binaries, every output file compared byte for byte.
#
#   scripts/same_bytes.py BASE NEW [--work DIR] [--only NAME,...] [--threads N]
#
# BASE, NEW: an isoloft binary or a build folder holding one. Each binary's
# outputs go to WORK/<sha256 of the binary and its isoloft-cli>/ and are kept: a binary already run
# (every case done) is not run again, so a baseline costs its run once.
# Cases: the bundled frog (scripts/example.sh's command, the label partition;
# and independent labels with --volume), the shared RT set with every ROI
# (meshes, volume table, RT-STRUCT), the analytic kit of paper/accuracy.md
# (`isoloft synth`, contours, masks and polylines) with --method isoloft,
# marker2006 and levin, a tilted-tube kit case with the track z scheme, a
# --dump-stages run, and a sparse AAL label volume (every 4th slice, five
# labels, as tests/io/test_volume.cpp) with its dense --labelmap.
# Compared: every file, byte for byte, except where a run's bytes are its own
# by design: the JSON report without its timing, memory, heap, thread and
# version fields; an RT-STRUCT without its new UIDs, creation date and time
# (pydicom). The synth outputs are outputs too (compared). Exit 0 iff same.
import argparse
import gzip
import hashlib
import json
import os
import struct
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RTSS = Path(os.environ.get("RTSS", ROOT.parent / "shared/data/rtstruct/rtss.dcm"))
AAL = Path(os.environ.get("AAL", "/usr/share/mricron/templates/aal.nii.gz"))
AAL_LABELS = (37, 41, 71, 73, 77)  # hippocampus, amygdala, caudate, putamen, thalamus (left), as the tests

KIT = ("sphere", "torus", "branching-cylinders", "two-blobs")  # paper/accuracy.md's shapes, a selection
METHODS = ("isoloft", "marker2006", "levin")


def cases():
    """(name, [argv after the binary], ...) per case; paths relative to the binary's folder."""
    out = []
    frog = str(ROOT / "data/frog")
    out.append(("frog", [["reconstruct", frog, "--input", "labels", "--z-spacing", "6", "--pixel-size", "1",
                          "-o", "frog/frog.ply", "--report", "frog/report.json", "--volumes", "frog/volumes.csv"]]))
    out.append(("frog_independent", [["reconstruct", frog, "--input", "labels", "--z-spacing", "6", "--labels", "2,6",
                                      "--independent-labels", "-o", "frog_independent/f.ply", "--volume",
                                      "frog_independent/f.nrrd", "--report", "frog_independent/report.json"]]))
    out.append(("frog_partition_volume", [["reconstruct", frog, "--input", "labels", "--z-spacing", "6", "--labels",
                                           "2,6", "--method", "levin", "-o", "frog_partition_volume/f.ply", "--volume",
                                           "frog_partition_volume/f.nrrd"]]))
    out.append(("rt", [["reconstruct", str(RTSS), "-o", "rt/rt.ply", "--report", "rt/report.json", "--volumes",
                        "rt/volumes.csv", "--rtstruct", "rt/rt.dcm"]]))
    out.append(("rt_marker2006", [["reconstruct", str(RTSS), "--method", "marker2006", "-o", "rt_marker2006/rt.dcm"]]))
    for shape in KIT:
        steps = [["synth", shape, "--size", "128", "--z-spacing", "8", "--out", f"kit_{shape}/stack"]]
        for m in METHODS:
            steps.append(["reconstruct", f"kit_{shape}/stack", "--z-spacing", "8", "--method", m,
                          "-o", f"kit_{shape}/{m}.ply", "--report", f"kit_{shape}/{m}.json"])
        out.append((f"kit_{shape}", steps))
    for kind, shape in (("masks", "ellipsoid"), ("polylines", "tilted-torus")):
        name = f"kit_{kind}_{shape}"
        steps = [["synth", shape, "--size", "128", "--z-spacing", "8", "--kind", kind, "--out", f"{name}/stack"]]
        src = f"{name}/stack/stack.txt" if kind == "polylines" else f"{name}/stack"
        extra = [] if kind == "polylines" else ["--input", "masks", "--z-spacing", "8"]
        for m in METHODS:
            steps.append(["reconstruct", src, *extra, "--method", m, "-o", f"{name}/{m}.ply", "--report",
                          f"{name}/{m}.json"])
        out.append((name, steps))
    out.append(("kit_tube_track", [
        ["synth", "tube80_r3_s8", "--kind", "masks", "--out", "kit_tube_track/stack"],
        ["reconstruct", "kit_tube_track/stack", "--input", "masks", "--z-spacing", "8",
         "--z-scheme", "track", "-o", "kit_tube_track/track.ply", "--report", "kit_tube_track/track.json"],
    ]))
    out.append(("dump_stages", [
        ["synth", "torus", "--size", "64", "--z-spacing", "6", "--out", "dump_stages/stack"],
        ["reconstruct", "dump_stages/stack", "--z-spacing", "6", "--method", "marker2006", "-o", "dump_stages/t.ply",
         "--dump-stages", "dump_stages/stages"],
    ]))
    out.append(("aal", [
        ["reconstruct", "@aal", "--input", "labels", "-o", "aal/aal.ply", "--labelmap", "aal/dense.nii.gz",
         "--report", "aal/report.json", "--volumes", "aal/volumes.csv"],
        ["reconstruct", "@aal", "--input", "labels", "--independent-labels", "--method", "levin", "-o",
         "aal/levin.ply", "--labelmap", "aal/levin.nii.gz"],
    ]))
    return out


def sparse_aal(dst: Path) -> Path:
    """AAL with only AAL_LABELS on every 4th axial slice (NIfTI-1, written once)."""
    if dst.exists():
        return dst
    import numpy as np
    raw = gzip.decompress(AAL.read_bytes())
    if struct.unpack("<i", raw[:4])[0] != 348:
        sys.exit(f"same_bytes: {AAL}: not a little-endian NIfTI-1 file")
    dims = struct.unpack("<8h", raw[40:56])
    code = struct.unpack("<h", raw[70:72])[0]
    offset = int(struct.unpack("<f", raw[108:112])[0])
    dtype = {2: np.uint8, 4: np.int16, 8: np.int32, 16: np.float32, 512: np.uint16}.get(code)
    if dtype is None:
        sys.exit(f"same_bytes: {AAL}: NIfTI datatype {code} not handled")
    nx, ny, nz = dims[1:4]
    data = np.frombuffer(raw, dtype=dtype, count=nx * ny * nz, offset=offset).reshape(nz, ny, nx).copy()
    keep = np.isin(data, AAL_LABELS)
    keep[np.arange(nz) % 4 != 0] = False
    data[~keep] = 0
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_suffix(".tmp")
    tmp.write_bytes(gzip.compress(raw[:offset] + data.tobytes() + raw[offset + data.nbytes:], mtime=0))
    tmp.rename(dst)
    return dst


def binary_of(arg: str) -> Path:
    p = Path(arg)
    if p.is_dir():
        p = p / "isoloft"
    if not (p.is_file() and os.access(p, os.X_OK)):
        sys.exit(f"same_bytes: {arg}: not an isoloft binary or a build folder holding one")
    return p.resolve()


def digest_of(binary: Path) -> str:
    """The binary's sha256 (16 hex digits), with the isoloft-cli beside it: the
    `isoloft` launcher execs that one, and is the same file in every build."""
    h = hashlib.sha256(binary.read_bytes())
    cli = binary.parent / "isoloft-cli"
    if cli.is_file():
        h.update(cli.read_bytes())
    return h.hexdigest()[:16]


def run_all(binary: Path, work: Path, only, threads: int, aal: Path, again: bool = False) -> Path:
    digest = digest_of(binary)
    root = work / (digest + (".again" if again else ""))
    root.mkdir(parents=True, exist_ok=True)
    for name, steps in cases():
        if only and name not in only:
            continue
        done = root / name / ".done"
        if done.exists():
            continue
        (root / name).mkdir(exist_ok=True)
        for argv in steps:
            argv = [str(aal) if a == "@aal" else a for a in argv]
            if argv[0] == "reconstruct":
                argv += ["--threads", str(threads), "-q"]
            r = subprocess.run([str(binary), *argv], cwd=root, capture_output=True, text=True)
            (root / name / ".log").open("a").write(" ".join(argv) + f"\nexit {r.returncode}\n{r.stderr}{r.stdout}")
            if r.returncode != 0:
                sys.exit(f"same_bytes: {binary} {' '.join(argv)}: exit {r.returncode}\n{r.stderr}")
        done.write_text(str(binary) + "\n")
        print(f"same_bytes: {binary.parent.name}/{binary.name} {name}: done", flush=True)
    return root


# Report fields that are the run's own, not the reconstruction's: wall times,
# peak memory, the build's version; the command without the binary's path.
VOLATILE_KEYS = {"timings_s", "peak_memory_mib", "isoloft"}


def strip(j, top=True):
    if isinstance(j, dict):
        out = {k: strip(v, False) for k, v in j.items() if k not in VOLATILE_KEYS}
        if top and isinstance(out.get("command"), str):
            out["command"] = out["command"].split(" ", 1)[-1]
        return out
    if isinstance(j, list):
        return [strip(v, False) for v in j]
    return j


# An RT-STRUCT's identity of its new instance (UIDs, creation time, software),
# and the file meta group's length, which follows its UID's (the UID holds the
# process id: 4 or 5 digits).
DICOM_VOLATILE = ("SOPInstanceUID", "MediaStorageSOPInstanceUID", "SeriesInstanceUID", "InstanceCreationDate",
                  "InstanceCreationTime", "StructureSetDate", "StructureSetTime", "SoftwareVersions",
                  "FileMetaInformationGroupLength")


def dicom_text(path: Path) -> str:
    import pydicom
    ds = pydicom.dcmread(str(path))
    for ds_ in (ds, ds.file_meta):
        for k in DICOM_VOLATILE:
            if k in ds_:
                delattr(ds_, k)
    return json.dumps(ds.file_meta.to_json_dict(), sort_keys=True) + json.dumps(ds.to_json_dict(), sort_keys=True)


def same(a: Path, b: Path) -> bool:
    if a.suffix == ".json":
        return strip(json.loads(a.read_text())) == strip(json.loads(b.read_text()))
    if a.suffix == ".dcm":
        return dicom_text(a) == dicom_text(b)
    return a.read_bytes() == b.read_bytes()


def compare(ra: Path, rb: Path, only) -> int:
    bad = files = 0
    for name, _ in cases():
        if only and name not in only:
            continue
        fa = sorted(p.relative_to(ra) for p in (ra / name).rglob("*") if p.is_file() and not p.name.startswith("."))
        fb = sorted(p.relative_to(rb) for p in (rb / name).rglob("*") if p.is_file() and not p.name.startswith("."))
        if fa != fb:
            print(f"DIFFERENT file lists in {name}: only base {sorted(set(fa) - set(fb))}, "
                  f"only new {sorted(set(fb) - set(fa))}")
            bad += 1
        for rel in sorted(set(fa) & set(fb)):
            files += 1
            if not same(ra / rel, rb / rel):
                print(f"DIFFERENT {rel}")
                bad += 1
    print(f"same_bytes: {files} files compared, {bad} different")
    return 1 if bad else 0


def main():
    ap = argparse.ArgumentParser(description="Run the same-bytes cases with two isoloft binaries and compare.")
    ap.add_argument("base")
    ap.add_argument("new")
    ap.add_argument("--work", default="/tmp/isoloft_same_bytes", help="outputs, per binary (kept)")
    ap.add_argument("--only", default="", help="comma-separated case names")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--list", action="store_true", help="print the case names")
    a = ap.parse_args()
    if a.list:
        for name, _ in cases():
            print(name)
        return 0
    only = set(filter(None, a.only.split(",")))
    work = Path(a.work).resolve()
    aal = sparse_aal(work / "inputs/aal_sparse.nii.gz")
    ba, bb = binary_of(a.base), binary_of(a.new)
    ra = run_all(ba, work, only, a.threads, aal)
    # The same binary twice: a second run of its own (a determinism check).
    rb = run_all(bb, work, only, a.threads, aal, again=ra == work / digest_of(bb))
    return compare(ra, rb, only)


if __name__ == "__main__":
    sys.exit(main())
