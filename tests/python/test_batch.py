"""Cohorts on Dask: one CLI run per manifest row, the bytes of one-by-one
runs, failures collected, finished cases skipped on a rerun."""

import csv
import subprocess

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
