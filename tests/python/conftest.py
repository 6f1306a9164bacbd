"""Shared fixtures: the CLI built beside the module (ctest passes its path)
and the repository's data, so Python results can be compared with the CLI's."""

import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("ISOLOFT_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
CLI = os.environ.get("ISOLOFT_CLI", str(SOURCE_DIR / "build" / "isoloft"))


def run_cli(*args):
    """Runs `isoloft ARGS...`; fails the test with its stderr if it fails."""
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"isoloft {' '.join(map(str, args))}: {r.stderr}"
    return r


@pytest.fixture(scope="session")
def data_dir():
    return SOURCE_DIR / "data"


def dciodvfy_errors(path):
    """dicom3tools' dciodvfy on a DICOM file: its "Error" lines (skips the test
    if dciodvfy is missing; fails it if dciodvfy does not see an RT Structure Set)."""
    import shutil
    dciodvfy = shutil.which("dciodvfy")
    if dciodvfy is None:
        pytest.skip("dciodvfy (Debian package dicom3tools, installed by scripts/setup.sh --full) is not on PATH")
    r = subprocess.run([dciodvfy, str(path)], capture_output=True, text=True)
    lines = (r.stdout + r.stderr).splitlines()
    assert "RTStructureSet" in lines, f"dciodvfy did not recognise the IOD: {lines[:5]}"
    return [line for line in lines if line.startswith("Error")]
