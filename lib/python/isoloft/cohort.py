"""Cohorts: one `isoloft reconstruct` per manifest row, on Dask distributed.

    isoloft batch MANIFEST.csv --out DIR [--workers N | --scheduler ADDRESS]
    python3 -m isoloft.cohort MANIFEST.csv --out DIR ...       (what `isoloft batch` runs)
    isoloft.batch("cases.csv", "out/", workers=2)              (the same from Python)

The manifest is a CSV with a header: `input` (a path; relative paths are
relative to the manifest's folder), `name` (the case's folder and file stem;
default the input's stem) and `options` (the case's `isoloft reconstruct`
flags, shell-quoted, e.g. `--roi Heart --method levin`). Case NAME is run
as `isoloft reconstruct INPUT OPTIONS -o NAME.ply --report NAME.json
--threads T -q` in DIR/NAME/ (so relative output flags such as `--volume
v.nrrd` land there too): one task per case, the same command and bytes as
a one-by-one run. A case whose report DIR/NAME/NAME.json exists is done (the
CLI writes a case's files all together or none) and is skipped on a rerun;
a failed case is recorded and the batch goes on. DIR/summary.csv lists every
case: name, input, status (ok, failed, skipped), exit code, seconds, error.
"""

import argparse
import csv
import os
import pathlib
import shlex
import subprocess
import sys
import time

SUMMARY_FIELDS = ["name", "input", "status", "exit_code", "seconds", "error"]
# The local cluster's Dask settings: its workers only wait for CLI processes.
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                        "distributed.admin.system-monitor.interval": "5s"}


def default_cli():
    """The isoloft CLI this package belongs to."""
    from .cli import cli_path
    return cli_path()


def read_manifest(manifest):
    """The cases of a manifest (a CSV path, or rows as dicts): dicts with
    input (absolute), name and options (a list of flags)."""
    if isinstance(manifest, (str, os.PathLike)):
        path = pathlib.Path(manifest)
        base = path.resolve().parent
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        where = str(path)
    else:
        base, rows, where = pathlib.Path.cwd(), [dict(r) for r in manifest], "manifest"
    cases, names = [], set()
    for i, row in enumerate(rows, start=2 if where != "manifest" else 0):
        if not row.get("input"):
            raise ValueError(f"{where}: row {i}: no 'input'")
        src = pathlib.Path(row["input"])
        src = src if src.is_absolute() else base / src
        name = (row.get("name") or "").strip() or src.name.split(".")[0]
        if name in names:
            raise ValueError(f"{where}: row {i}: the name '{name}' is used twice")
        if "/" in name or name in (".", ".."):
            raise ValueError(f"{where}: row {i}: the name '{name}' is not a folder name")
        names.add(name)
        options = row.get("options") or ""
        cases.append({"input": str(src), "name": name,
                      "options": shlex.split(options) if isinstance(options, str) else list(options)})
    return cases


def case_command(case, cli, threads=1, fmt="ply"):
    """The one-by-one command of a case (run in its folder)."""
    name = case["name"]
    return [cli, "reconstruct", case["input"], *case["options"], "-o", f"{name}.{fmt}", "--report",
            f"{name}.json", "--threads", str(threads), "-q"]


def run_case(case, out, cli, threads=1, fmt="ply"):
    """Runs one case (a Dask task): its summary row."""
    folder = pathlib.Path(out) / case["name"]
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    r = subprocess.run(case_command(case, cli, threads, fmt), cwd=folder, capture_output=True, text=True)
    errors = [line for line in r.stderr.splitlines() if line.startswith("isoloft: error:")]
    error = errors[-1][len("isoloft: error: "):] if errors else (r.stderr.strip().splitlines() or [""])[-1]
    return {"name": case["name"], "input": case["input"], "status": "ok" if r.returncode == 0 else "failed",
            "exit_code": r.returncode, "seconds": round(time.monotonic() - t0, 3),
            "error": "" if r.returncode == 0 else error}


def _write_summary(out, rows):
    path = pathlib.Path(out) / "summary.csv"
    tmp = path.with_name(f".summary.csv.tmp{os.getpid()}")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=SUMMARY_FIELDS)
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def batch(manifest, out, *, workers=None, scheduler=None, threads=1, format="ply", force=False, cli=None,
          on_case=None):
    """Runs every case of `manifest` as a task on Dask distributed: a local
    cluster of `workers` processes (default: the cores / threads), or the
    scheduler at `scheduler` (its workers must see the same paths and have
    isoloft installed). threads: --threads of each case. force: rerun cases
    already done. on_case(row) is called as each case ends. Returns the
    summary rows (also written to OUT/summary.csv), in manifest order."""
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    if workers is not None and scheduler is not None:
        raise ValueError("give either workers or scheduler, not both")
    cli = cli or default_cli()
    out = pathlib.Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    cases = read_manifest(manifest)
    rows = {}
    todo = []
    for case in cases:
        if not force and (out / case["name"] / f"{case['name']}.json").exists():
            rows[case["name"]] = {"name": case["name"], "input": case["input"], "status": "skipped",
                                  "exit_code": 0, "seconds": 0.0, "error": ""}
        else:
            todo.append(case)
    if todo:
        if scheduler is None:
            n = workers or max(1, (os.cpu_count() or 1) // max(1, threads))
            # Workers in this process, one thread each: a task is a CLI process the worker only waits for
            # (the GIL is free meanwhile), and worker processes cost 5.2 s of CPU to start against 1.6 s
            # (docs/decisions.md, cohorts).
            # No statistical profiler (it samples every worker thread each 10 ms), slower watchdog ticks and
            # system monitor: 3.1 -> 1.8-2.2 s of CPU for 8 tasks of 3 s (docs/decisions.md, cohorts).
            with dask.config.set(LOCAL_CLUSTER_CONFIG):
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=False, dashboard_address=None)
        else:
            cluster = None
        try:
            with Client(cluster if cluster is not None else scheduler) as client:
                futures = client.map(run_case, todo, out=str(out), cli=cli, threads=threads, fmt=format,
                                     pure=False, key=[f"isoloft-{c['name']}" for c in todo])
                for future in as_completed(futures):
                    row = future.result()
                    rows[row["name"]] = row
                    if on_case:
                        on_case(row)
                    _write_summary(out, [rows[c["name"]] for c in cases if c["name"] in rows])
        finally:
            if cluster is not None:
                cluster.close()
    result = [rows[c["name"]] for c in cases]
    _write_summary(out, result)
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(prog="isoloft batch", description=__doc__.split("\n\n")[0])
    parser.add_argument("manifest", help="CSV with columns input, name, options (isoloft reconstruct flags)")
    parser.add_argument("--out", required=True, help="output folder: one folder per case and summary.csv")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="a local Dask cluster of N worker processes (default: cores)")
    where.add_argument("--scheduler", help="a running Dask scheduler's address (tcp://host:8786)")
    parser.add_argument("--threads", type=int, default=1, help="--threads of each case (default 1)")
    parser.add_argument("--format", default="ply", choices=["ply", "obj", "stl", "off", "vtp", "vtk"],
                        help="mesh format of each case (default ply)")
    parser.add_argument("--force", action="store_true", help="rerun cases already done")
    parser.add_argument("--cli", help="the isoloft CLI to run (default: this package's)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no line per case")
    a = parser.parse_args(argv)
    if a.workers is not None and a.workers < 1:
        parser.error("--workers must be >= 1")

    def report(row):
        if not a.quiet:
            print(f"isoloft batch: {row['name']}: {row['status']} ({row['seconds']} s)"
                  + (f": {row['error']}" if row["error"] else ""), file=sys.stderr)

    try:
        rows = batch(a.manifest, a.out, workers=a.workers, scheduler=a.scheduler, threads=a.threads,
                     format=a.format, force=a.force, cli=a.cli, on_case=report)
    except (OSError, ValueError) as e:
        print(f"isoloft batch: error: {e}", file=sys.stderr)
        return 1
    failed = sum(r["status"] == "failed" for r in rows)
    if not a.quiet:
        print(f"isoloft batch: {len(rows)} cases, {failed} failed, "
              f"{sum(r['status'] == 'skipped' for r in rows)} skipped; {pathlib.Path(a.out) / 'summary.csv'}",
              file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
