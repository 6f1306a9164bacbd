"""Where this package's isoloft CLI is (shared by isoloft.cli and
isoloft.cohort, which import each other no more)."""

import os
import pathlib


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
