"""Cohorts on Dask: one CLI run per manifest row, the bytes of one-by-one
runs, failures collected, finished cases skipped on a rerun."""

import csv
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from conftest import CLI, run_cli
from test_isoloft import read_bytes

pytest.importorskip("distributed")
import isoloft  # noqa: E402


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    d = tmp_path_factory.mktemp("cohort")
    run_cli("synth", "sphere", "--size", 64, "--z-spacing", 8, "--out", d / "sphere")
    run_cli("synth", "torus", "--size", 64, "--z-spacing", 6, "--kind", "masks", "--out", d / "torus")
    rows = [{"input": "sphere", "name": "sphere", "options": "--z-spacing 8"},
            {"input": "torus", "name": "torus", "options": "--z-spacing 6 --input masks --volume v.nrrd"},
            {"input": "missing", "name": "broken", "options": ""}]
    path = d / "cases.csv"
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["input", "name", "options"])
        w.writeheader()
        w.writerows(rows)
    return path


def test_batch_gives_one_by_one_bytes_collects_errors_and_resumes(tmp_path, manifest):
    out = tmp_path / "out"
    ended = []
    rows = isoloft.batch(manifest, out, workers=2, on_case=ended.append)
    assert [r["name"] for r in rows] == ["sphere", "torus", "broken"]
    assert [r["status"] for r in rows] == ["ok", "ok", "failed"] and len(ended) == 3
    assert "missing" in rows[2]["error"] and rows[2]["exit_code"] == 1
    # Each case's files are those of the same command run alone.
    src = manifest.parent
    one = tmp_path / "one"
    one.mkdir()
    run_cli("reconstruct", src / "sphere", "--z-spacing", 8, "-o", one / "sphere.ply", "-q")
    run_cli("reconstruct", src / "torus", "--z-spacing", 6, "--input", "masks", "--volume", one / "v.nrrd", "-o",
            one / "torus.ply", "-q")
    for a, b in [("sphere/sphere.ply", "sphere.ply"), ("torus/torus.ply", "torus.ply"), ("torus/v.nrrd", "v.nrrd")]:
        assert read_bytes(out / a) == read_bytes(one / b), a
    with open(out / "summary.csv", newline="") as f:
        assert [r["status"] for r in csv.DictReader(f)] == ["ok", "ok", "failed"]
    # A rerun through the CLI (`isoloft batch` runs python3 -m isoloft.cohort) skips the finished cases.
    r = subprocess.run([CLI, "batch", str(manifest), "--out", str(out), "--workers", "1", "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 1, r.stderr  # the broken case fails again
    with open(out / "summary.csv", newline="") as f:
        assert [r["status"] for r in csv.DictReader(f)] == ["skipped", "skipped", "failed"]


def test_batch_refuses_a_bad_manifest(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("input,name,options\na.png,x,\nb.png,x,\n")
    with pytest.raises(ValueError, match="row 3: the name 'x' is used twice"):
        isoloft.batch(bad, tmp_path / "out")


# ---------------------------------------------------------------- hostile manifests (issue 39)

def _write(path, text, encoding="utf-8"):
    path.write_bytes(text.encode(encoding))
    return path


@pytest.fixture(scope="module")
def sphere_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    run_cli("synth", "sphere", "--size", 48, "--z-spacing", 8, "--out", d / "sphere")
    return d


def _summary(out):
    with open(out / "summary.csv", newline="") as f:
        return {r["name"]: r for r in csv.DictReader(f)}


def test_bad_rows_are_recorded_as_failed_and_the_good_ones_run(sphere_dir, tmp_path):
    src = sphere_dir / "sphere"
    long_name = "n" * 300
    manifest = _write(tmp_path / "cases.csv", "input,name,options\n"
                      f"{src},good,--z-spacing 8\n"
                      f"{src},abs,--z-spacing 8 --volume {tmp_path}/escaped.nrrd\n"
                      f"{src},up,--z-spacing 8 --volumes ../../escaped.csv\n"
                      f"{src},eq,--z-spacing 8 --volumes=../escaped.csv\n"
                      f"{src},summary.csv,--z-spacing 8\n"
                      f"{src},a\0b,--z-spacing 8\n"
                      f"{src},{long_name},--z-spacing 8\n"
                      f"{src},quote,--roi \"Heart\n"
                      f",noinput,\n"
                      f"{src},own,--report mine.json\n")
    out = tmp_path / "out"
    rows = {r["name"]: r for r in isoloft.batch(manifest, out, workers=1)}
    assert rows["good"]["status"] == "ok", rows["good"]
    want = {"abs": "--volume /", "up": "--volumes ../../escaped.csv: outputs stay in the case's folder",
            "eq": "--volumes ../escaped.csv: outputs stay", "summary.csv": "is reserved for the batch's summary.csv",
            "a\0b": "holds a NUL byte", long_name: "is longer than 246 bytes", "quote": "options: No closing quotation",
            "noinput": "no 'input'", "own": "--report is set by the batch"}
    for name, message in want.items():
        assert rows[name]["status"] == "failed" and message in rows[name]["error"], (name, rows[name])
        assert rows[name]["error"].startswith(f"{manifest}: row "), rows[name]
    assert not (tmp_path / "escaped.nrrd").exists() and not (tmp_path / "escaped.csv").exists()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["good", "summary.csv"]
    summary = _summary(out)
    assert summary["summary.csv"]["status"] == "failed" and summary["good"]["status"] == "ok"
    assert summary["a\\x00b"]["error"].endswith("holds a NUL byte")


def test_a_fifo_or_a_folder_manifest_is_refused(tmp_path):
    fifo = tmp_path / "cases.csv"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"cases.csv: the manifest is not a regular file"):
        isoloft.batch(fifo, tmp_path / "out")
    with pytest.raises(ValueError, match=r"the manifest is not a regular file"):
        isoloft.batch(tmp_path, tmp_path / "out")
    assert not (tmp_path / "out").exists(), "nothing written"


def test_a_bom_is_read_and_an_unbalanced_quote_is_reported(sphere_dir, tmp_path):
    bom = _write(tmp_path / "bom.csv", f"input,name,options\n{sphere_dir / 'sphere'},s,--z-spacing 8\n", "utf-8-sig")
    assert [r["status"] for r in isoloft.batch(bom, tmp_path / "out", workers=1)] == ["ok"]
    open_quote = _write(tmp_path / "quote.csv", "input,name,options\na,x,\"--z-spacing 8\nb,y,\nc,z,\"\n")
    with pytest.raises(ValueError, match=r"quote.csv: line \d+: a field spans several lines \(an unbalanced quote\?\)"):
        isoloft.batch(open_quote, tmp_path / "out2")
    never_closed = _write(tmp_path / "never.csv", "input,name,options\na,x,\"--z-spacing 8\nb,y,\n")
    with pytest.raises(ValueError, match=r"never.csv: line \d+: unexpected end of data \(an unbalanced quote\?\)"):
        isoloft.batch(never_closed, tmp_path / "out3")


def test_a_rerun_with_another_format_runs_and_names_are_text_in_the_summary(sphere_dir, tmp_path):
    manifest = _write(tmp_path / "cases.csv", f"input,name,options\n{sphere_dir / 'sphere'},=1+2,--z-spacing 8\n")
    out = tmp_path / "out"
    assert [r["status"] for r in isoloft.batch(manifest, out, workers=1)] == ["ok"]
    assert [r["status"] for r in isoloft.batch(manifest, out, workers=1)] == ["skipped"]
    assert [r["status"] for r in isoloft.batch(manifest, out, workers=1, format="obj")] == ["ok"]
    assert (out / "=1+2" / "=1+2.obj").is_file()
    text = (out / "summary.csv").read_text()
    assert "\n'=1+2," in text, text
    assert all(not line.startswith(("=", "+", "-", "@")) for line in text.splitlines())


def test_sigterm_stops_the_running_cases(sphere_dir, tmp_path):
    # A stand-in CLI that records its pid and waits: the batch must stop it.
    pids = tmp_path / "pids"
    pids.mkdir()
    fake = _write(tmp_path / "fake_isoloft", f"#!/bin/sh\necho $$ > {pids}/$$\nexec sleep 60\n")
    fake.chmod(0o755)
    manifest = _write(tmp_path / "cases.csv", f"input,name,options\n{sphere_dir / 'sphere'},slow,\n")
    batch = subprocess.Popen([sys.executable, "-m", "isoloft.cohort", str(manifest), "--out", str(tmp_path / "out"),
                              "--workers", "1", "--cli", str(fake), "-q"])
    deadline = time.monotonic() + 60
    while not list(pids.iterdir()) and time.monotonic() < deadline:
        time.sleep(0.1)
    (child,) = [int(p.name) for p in pids.iterdir()]
    batch.send_signal(signal.SIGTERM)
    assert batch.wait(timeout=30) == -signal.SIGTERM
    deadline = time.monotonic() + 10
    while os.path.exists(f"/proc/{child}") and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not os.path.exists(f"/proc/{child}"), "the case's process outlived the batch"


def test_the_cli_batch_uses_the_package_beside_it_and_dask_stays_under_out(sphere_dir, tmp_path):
    # A user's own `isoloft` package first on PYTHONPATH: a copy of the CLI outside the build tree
    # (an installed binary) must leave it first; the build tree's binary uses its own package.
    user = tmp_path / "user"
    (user / "isoloft").mkdir(parents=True)
    (user / "isoloft" / "__init__.py").write_text("")
    (user / "isoloft" / "cohort.py").write_text("print('the user package')\n")
    copy = tmp_path / "bin" / "isoloft"
    copy.parent.mkdir()
    shutil.copy2(CLI, copy)  # the launcher, and the CLI it starts from beside it
    shutil.copy2(os.path.join(os.path.dirname(CLI), "isoloft-cli"), copy.parent / "isoloft-cli")
    env = {**os.environ, "PYTHONPATH": str(user)}
    r = subprocess.run([str(copy), "batch", "x.csv", "--out", str(tmp_path / "o")], env=env, capture_output=True,
                       text=True)
    assert r.stdout.strip() == "the user package", (r.stdout, r.stderr)
    r = subprocess.run([CLI, "batch", "--help"], env=env, capture_output=True, text=True)
    assert r.returncode == 0 and "the user package" not in r.stdout and "--out" in r.stdout, (r.stdout, r.stderr)
    # Dask's local directory: under --out, none in TMPDIR.
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    manifest = _write(tmp_path / "cases.csv", f"input,name,options\n{sphere_dir / 'sphere'},s,--z-spacing 8\n")
    r = subprocess.run([CLI, "batch", str(manifest), "--out", str(tmp_path / "out"), "--workers", "1", "-q"],
                       env={**os.environ, "TMPDIR": str(tmp)}, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert list(tmp.iterdir()) == [], list(tmp.iterdir())


def test_the_library_reads_the_manifest_for_files_and_rows(tmp_path):
    """isoloft.cohort.read_manifest is the library's (run/manifest.h): the
    fuzzed code reads the batch's rows, from a file or from dicts."""
    from isoloft.cohort import read_manifest
    manifest = _write(tmp_path / "m.csv", "input,name,options\n"
                      "a.png,glued,-ox.ply\n"
                      "a.png,rt,--rt-contours ../c.csv\n"
                      "sub/./b.png,,--roi 'Tumor Bed'\n"
                      "a.png,esc\x1b]0;x\x07/y,\n")
    cases = read_manifest(manifest)
    assert cases[0]["error"].endswith("row 2: -o is set by the batch")
    assert "row 3: --rt-contours ../c.csv: outputs stay in the case's folder" in cases[1]["error"]
    assert cases[2] == {"input": str(tmp_path.resolve() / "sub" / "b.png"), "name": "b",
                        "options": ["--roi", "Tumor Bed"]}
    assert "\x1b" not in cases[3]["error"] and "esc\\x1B]0;x\\x07/y" in cases[3]["error"]
    rows = read_manifest([{"input": "/in/a.png", "name": "x", "options": ["--volume", "/abs.nrrd"]}])
    assert rows[0]["error"] == "manifest: row 0: --volume /abs.nrrd: outputs stay in the case's folder " \
                               "(a relative path without '..')"
    with pytest.raises(isoloft.InputError, match=r"m2.csv: row 3: the name 'x' is used twice"):
        read_manifest(_write(tmp_path / "m2.csv", "input,name\na,x\nb,x\n"))


def _triangles(path):
    """A mesh's triangles by their corners' positions (each from its smallest corner), sorted."""
    import meshio
    import numpy as np
    m = meshio.read(path)
    t = m.points[m.cells_dict["triangle"]].astype(np.float32)  # (n, 3, 3)
    t = np.stack([np.roll(tri, -min(range(3), key=lambda k: tuple(tri[k])), axis=0) for tri in t])
    flat = t.reshape(len(t), 9)
    return flat[np.lexsort(flat.T[::-1])]


def test_z_slabs_join_to_the_one_piece_surface_and_refuse_other_outputs(sphere_dir, tmp_path):
    manifest = _write(tmp_path / "m.csv", "input,name,options\n"
                      f"{sphere_dir / 'sphere'},sphere,--z-spacing 8\n"
                      f"{sphere_dir / 'sphere'},volume,--z-spacing 8 --volume v.nrrd\n")
    whole = {r["name"]: r for r in isoloft.batch(manifest, tmp_path / "whole", workers=1)}
    assert whole["sphere"]["status"] == "ok", whole
    rows = {r["name"]: r for r in isoloft.batch(manifest, tmp_path / "slabs", workers=2, z_slabs=3)}
    assert rows["sphere"]["status"] == "ok", rows
    assert rows["volume"]["status"] == "failed" and "--z-slab" in rows["volume"]["error"], rows
    got, want = _triangles(tmp_path / "slabs" / "sphere" / "sphere.ply"), _triangles(tmp_path / "whole" / "sphere" / "sphere.ply")
    assert got.shape == want.shape and (got == want).all()
    assert [r["status"] for r in isoloft.batch(manifest, tmp_path / "slabs", workers=1, z_slabs=3)] == ["skipped", "failed"]
    with pytest.raises(ValueError, match="z_slabs"):
        isoloft.batch(manifest, tmp_path / "x", z_slabs=0)
