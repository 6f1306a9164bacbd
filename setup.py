"""Builds the extension `isoloft._isoloft` and the `isoloft` CLI with the
project's CMake (the CLI-only configuration plus the Python extension, for
the interpreter running this), for `pip install --no-build-isolation .` and
`python3 -m build --no-isolation --wheel`. Metadata: pyproject.toml."""

import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(isoloft VERSION ([0-9.]+)", text).group(1)


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    """cmake -S ROOT -B <build_temp>/cmake, targets _isoloft and isoloft; the
    extension goes where setuptools expects it, the CLI beside it (bin/)."""

    def build_extension(self, ext):
        build = pathlib.Path(self.build_temp).resolve() / "cmake"
        configure = ["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                     "-DISOLOFT_BUILD_TESTS=OFF", "-DISOLOFT_BUILD_VALIDATION=OFF",
                     "-DISOLOFT_BUILD_EXPERIMENTS=OFF", "-DISOLOFT_BUILD_PYTHON=ON",
                     f"-DPython_EXECUTABLE={sys.executable}"]
        if shutil.which("ccache"):
            configure += ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache", "-DCMAKE_C_COMPILER_LAUNCHER=ccache"]
        jobs = os.environ.get("ISOLOFT_JOBS", str(os.cpu_count() or 1))
        subprocess.run(configure, check=True)
        subprocess.run(["cmake", "--build", str(build), "-j", jobs, "--target", "_isoloft", "isoloft"], check=True)
        target = pathlib.Path(self.get_ext_fullpath(ext.name)).resolve()
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(next((build / "python" / "isoloft").glob("_isoloft*.so")), target)
        cli = target.parent / "bin" / "isoloft"
        cli.parent.mkdir(exist_ok=True)
        shutil.copy2(build / "isoloft", cli)


setup(version=project_version(), ext_modules=[CMakeExtension("isoloft._isoloft")],
      cmdclass={"build_ext": CMakeBuild}, options={"build": {"build_base": "build-pip"}})
