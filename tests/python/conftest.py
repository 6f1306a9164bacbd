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
