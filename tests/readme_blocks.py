"""Runs every ```sh and ```python block of README.md (the ctest test
`readme_blocks`), so the README's examples cannot go stale.

A block preceded by a line `<!-- not run: REASON -->` is skipped (the set-up
commands themselves, files that stand for the reader's own); every other sh
or python block runs, in order, in one scratch folder holding `data`,
`build` and `scripts` of the checkout, with the built `isoloft` first on
PATH and the built package first on PYTHONPATH. A failing block is reported
with its README line and output.

usage: readme_blocks.py README BUILD_DIR [PYTHON]
"""

import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

FENCE = re.compile(r"^```(\w*)\s*$")
SKIP = re.compile(r"^<!-- not run: (.+) -->$")


def blocks(readme):
    """(first line number, language, code, skip reason) of every fenced block."""
    lines = readme.read_text().splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        lang, start = m.group(1), i + 1
        j = start
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        prev = next((lines[k].strip() for k in range(i - 1, -1, -1) if lines[k].strip()), "")
        skip = SKIP.match(prev)
        out.append((start + 1, lang, "\n".join(lines[start:j]) + "\n", skip.group(1) if skip else None))
        i = j + 1
    return out


def main(argv):
    readme, build = pathlib.Path(argv[1]).resolve(), pathlib.Path(argv[2]).resolve()
    python = argv[3] if len(argv) > 3 else sys.executable
    root = readme.parent
    failed, ran, skipped = [], 0, 0
    with tempfile.TemporaryDirectory(prefix="isoloft_readme_") as tmp:
        work = pathlib.Path(tmp)
        for name, target in (("data", root / "data"), ("scripts", root / "scripts"), ("build", build)):
            (work / name).symlink_to(target)
        bin_dir = work / ".bin"
        bin_dir.mkdir()
        (bin_dir / "isoloft").symlink_to(build / "isoloft")
        (bin_dir / "python3").symlink_to(python)
        env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
               "PYTHONPATH": os.pathsep.join(p for p in (str(build / "python"), os.environ.get("PYTHONPATH")) if p)}
        for line, lang, code, skip in blocks(readme):
            if lang not in ("sh", "bash", "python"):
                continue
            if skip:
                skipped += 1
                print(f"README.md:{line}: {lang} block not run: {skip}")
                continue
            cmd = ["bash", "-euo", "pipefail", "-c", code] if lang != "python" else [python, "-c", code]
            t0 = time.monotonic()
            r = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True)
            ran += 1
            print(f"README.md:{line}: {lang} block: exit {r.returncode} in {time.monotonic() - t0:.1f} s")
            if r.returncode != 0:
                failed.append(line)
                print(f"--- stdout\n{r.stdout}--- stderr\n{r.stderr}---")
    print(f"{ran} blocks run, {skipped} not run, {len(failed)} failed" + (f" (lines {failed})" if failed else ""))
    return 1 if failed or not ran else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
