"""`isoloft` as an installed command: `isoloft batch ...` runs the cohort
runner (isoloft.cohort), anything else the CLI built with this package."""

import os
import pathlib
import sys


def cli_path():
    """The isoloft executable of this package: bundled by pip (isoloft/bin/),
    else the one built beside the module (a build tree)."""
    bundled = pathlib.Path(__file__).resolve().parent / "bin" / "isoloft"
    if bundled.is_file():
        return str(bundled)
    from . import _isoloft
    if os.path.isfile(_isoloft.cli_path):
        return _isoloft.cli_path
    raise FileNotFoundError("no isoloft CLI next to the isoloft package (reinstall it, or build target isoloft)")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["batch"]:
        from .cohort import main as batch_main
        return batch_main(argv[1:])
    exe = cli_path()
    os.execv(exe, [exe, *argv])


if __name__ == "__main__":
    sys.exit(main())
