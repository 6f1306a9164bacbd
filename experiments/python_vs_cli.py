#!/usr/bin/python3
"""Python module vs CLI on the bundled example (scripts/example.sh's run: the
frog labels, 6 px apart, one mesh per organ plus the coloured one), runs
alternating, medians of wall seconds, and the outputs compared byte for byte.

    /usr/bin/python3 experiments/python_vs_cli.py [--build build] [--runs 5] [--out DIR]

Prints JSON: per side the median (and all runs) of the whole process (start,
import, read, reconstruct, write) and, for Python, of the reconstruct() call
alone and of `import isoloft`.
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]

PY_RUN = """
import sys, time, json
t0 = time.perf_counter()
import isoloft
t1 = time.perf_counter()
res = isoloft.reconstruct(sys.argv[1], input="labels", z_spacing=6, pixel_size=1)
t2 = time.perf_counter()
res.save(sys.argv[2])
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "reconstruct": t2 - t1, "save": t3 - t2}))
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=str(ROOT / "build"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    build = pathlib.Path(a.build)
    out = pathlib.Path(a.out or tempfile.mkdtemp(prefix="isoloft_pyvscli_"))
    out.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(build / "python"))
    frog = str(ROOT / "data" / "frog")
    cli, py, py_parts = [], [], []
    for _ in range(a.runs):
        t = time.perf_counter()
        subprocess.run([str(build / "isoloft"), "reconstruct", frog, "--input", "labels", "--z-spacing", "6",
                        "--pixel-size", "1", "-o", str(out / "cli.ply"), "--quiet"], check=True)
        cli.append(time.perf_counter() - t)
        t = time.perf_counter()
        r = subprocess.run(["/usr/bin/python3", "-c", PY_RUN, frog, str(out / "py.ply")], check=True, env=env,
                           capture_output=True, text=True)
        py.append(time.perf_counter() - t)
        py_parts.append(json.loads(r.stdout))
    same = sorted(p.name for p in out.glob("cli*.ply"))
    identical = all((out / n).read_bytes() == (out / n.replace("cli", "py", 1)).read_bytes() for n in same)
    med = statistics.median
    print(json.dumps({
        "runs": a.runs,
        "cli_process_s": {"median": med(cli), "all": cli},
        "python_process_s": {"median": med(py), "all": py},
        "python_reconstruct_call_s": med(p["reconstruct"] for p in py_parts),
        "python_import_s": med(p["import"] for p in py_parts),
        "python_save_s": med(p["save"] for p in py_parts),
        "files_compared": len(same),
        "outputs_identical": identical,
    }, indent=2))
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
