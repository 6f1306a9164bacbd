"""`isoloft` as an installed command: `isoloft batch ...` runs the cohort
runner (isoloft.cohort), anything else the CLI built with this package."""

import os
import sys

from ._exe import cli_path

__all__ = ["cli_path", "main"]


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["batch"]:
        from .cohort import main as batch_main
        return batch_main(argv[1:])
    exe = cli_path()
    os.execv(exe, [exe, *argv])


if __name__ == "__main__":
    sys.exit(main())
