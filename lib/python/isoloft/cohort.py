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

Rows are checked before any case runs: a row whose name is not a plain
folder name (a NUL, a slash, longer than a file name may be, a dot first,
or the batch's own summary.csv), whose input is missing or whose options do
not parse or write outside DIR/NAME (an absolute path or `..` given to an
output flag) is recorded as failed, and the other rows run (the library
reads and checks the rows: isoloft/run/manifest.h). A case is done
when its report exists and was written by the same command (so a rerun with
another --format runs it again). A SIGTERM, SIGINT or SIGHUP stops the
running CLI processes (they remove their temp files) before the batch ends.
Dask's local work space is DIR/.dask.

With --z-slabs S each case is cut into S z slabs (`isoloft reconstruct
--z-slab I/S`, one task each, in DIR/NAME/slabs/), and each object's parts
are then joined (`isoloft join-slabs`, welded at the cuts and checked closed)
into NAME.FORMAT (one object) or NAME_<object>.FORMAT, the same surfaces as
the one-piece run's. The case's report NAME.json then lists the slabs' and
joins' reports. Column methods only; no other outputs.
"""

import argparse
import csv
import json
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

from ._exe import cli_path

SUMMARY_FIELDS = ["name", "input", "status", "exit_code", "seconds", "error"]
MESH_FORMATS = ("ply", "obj", "stl", "off", "vtp", "vtk")
# The local cluster's Dask settings: its workers only wait for CLI processes.
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                        "distributed.admin.system-monitor.interval": "5s"}
DASK_DIR = ".dask"


def default_cli():
    """The isoloft CLI this package belongs to."""
    return cli_path()


def read_manifest(manifest):
    """The cases of a manifest (a CSV path, or rows as dicts): dicts with
    input (absolute), name, options (a list of flags) and, for a row that
    cannot run, error (the case is recorded as failed, not run). Read and
    checked by the library (isoloft/run/manifest.h), the code the fuzzers
    run. InputError (a ValueError) for a manifest that cannot be read as
    rows at all, or a name used twice."""
    from . import _isoloft
    if isinstance(manifest, (str, os.PathLike)):
        return _isoloft._read_manifest(manifest)
    rows = [dict(r) for r in manifest]
    return _isoloft._check_manifest_rows(rows, os.getcwd(), "manifest", 0)


def case_command(case, cli, threads=1, fmt="ply"):
    """The one-by-one command of a case (run in its folder)."""
    name = case["name"]
    return [cli, "reconstruct", case["input"], *case["options"], "-o", f"{name}.{fmt}", "--report",
            f"{name}.json", "--threads", str(threads), "-q"]


# The CLI processes running now, stopped when the batch is stopped.
_children = set()
_children_lock = threading.Lock()
_stopping = threading.Event()  # set by a stop signal: no case starts after it


def _run_cli(case, command, folder):
    """Runs one CLI process in `folder`, stopped with the batch: (exit code, its error line)."""
    # Started and registered under one lock: a stop signal between the two once missed the child
    # (it ran on after the batch died).
    with _children_lock:
        if _stopping.is_set():
            return None, "the batch was stopped"
        p = subprocess.Popen(command, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _children.add(p)
    with p:
        try:
            _, stderr = p.communicate()
        finally:
            with _children_lock:
                _children.discard(p)
    errors = [line for line in stderr.splitlines() if line.startswith("isoloft: error:")]
    error = errors[-1][len("isoloft: error: "):] if errors else (stderr.strip().splitlines() or [""])[-1]
    return p.returncode, "" if p.returncode == 0 else error


def _row(case, t0, code, error):
    return {"name": case["name"], "input": case["input"], "status": "ok" if code == 0 else "failed",
            "exit_code": "" if code is None else code, "seconds": round(time.monotonic() - t0, 3), "error": error}


def run_case(case, out, cli, threads=1, fmt="ply"):
    """Runs one case (a Dask task): its summary row."""
    folder = pathlib.Path(out) / case["name"]
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    code, error = _run_cli(case, case_command(case, cli, threads, fmt), folder)
    return _row(case, t0, code, error)


def slab_command(case, cli, slab, slabs, threads=1):
    """Slab `slab` (1-based) of `slabs` of a case (run in its slabs folder)."""
    name = f"{case['name']}.s{slab}"
    return [cli, "reconstruct", case["input"], *case["options"], "--z-slab", f"{slab}/{slabs}", "-o", f"{name}.ply",
            "--report", f"{name}.json", "--threads", str(threads), "-q"]


def run_slab(case, out, cli, slab, slabs, threads=1):
    """One z slab of a case (a Dask task): (exit code, error, its report path, seconds)."""
    folder = pathlib.Path(out) / case["name"] / "slabs"
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    code, error = _run_cli(case, slab_command(case, cli, slab, slabs, threads), folder)
    return (code, f"slab {slab}/{slabs}: {error}" if code else "", str(folder / f"{case['name']}.s{slab}.json"),
            time.monotonic() - t0)


def _slabs_command(case, cli, slabs, fmt):
    """What a slab case's report records as its command."""
    return [*slab_command(case, cli, "I", slabs), "--join-format", fmt]


def join_case(case, slabs, out, cli, fmt="ply"):
    """Joins a case's slab meshes object by object (a Dask task after its
    slabs): its summary row (seconds: the slabs' and the joins'); NAME.json
    lists the slab and join reports."""
    t0 = time.monotonic() - sum(s[3] for s in slabs)
    for code, error, _, _ in slabs:
        if code != 0:
            return _row(case, t0, code, error)
    folder = pathlib.Path(out) / case["name"]
    reports = []
    for _, _, path, _ in slabs:
        with open(path) as f:
            reports.append(json.load(f))
    objects = [[o["file"] for o in r.get("objects", [])] for r in reports]
    if len({len(o) for o in objects}) != 1:
        return _row(case, t0, 1, "the slabs list different objects")
    joins = []
    one = len(objects[0]) == 1
    for k, first in enumerate(objects[0]):
        stem = pathlib.Path(first).stem  # NAME.s1 or NAME.s1_label5
        suffix = stem[len(f"{case['name']}.s1"):]
        target = f"{case['name']}{'' if one else suffix}.{fmt}"
        parts = [str(folder / "slabs" / pathlib.Path(o[k]).name) for o in objects]
        report = str(folder / "slabs" / f"{case['name']}{suffix}.join.json")
        code, error = _run_cli(case, [cli, "join-slabs", *parts, "-o", target, "--report", report], folder)
        if code != 0:
            return _row(case, t0, code, f"join {target}: {error}")
        joins.append(report)
    summary = {"command": " ".join(_slabs_command(case, cli, len(slabs), fmt)), "slabs": [s[2] for s in slabs],
               "joins": joins}
    tmp = folder / f".{case['name']}.json.tmp{os.getpid()}"
    tmp.write_text(json.dumps(summary, indent=2) + "\n")
    os.replace(tmp, folder / f"{case['name']}.json")
    return _row(case, t0, 0, "")


def _is_done(case, out, cli, threads, fmt, z_slabs=1):
    """The case's report exists and was written by this case's command
    (same options, format and slabs; --threads aside)."""
    report = out / case["name"] / f"{case['name']}.json"
    try:
        with open(report) as f:
            done = json.load(f).get("command", "")
    except (OSError, ValueError, AttributeError):
        return False
    want = _slabs_command(case, cli, z_slabs, fmt) if z_slabs > 1 else case_command(case, cli, threads, fmt)
    return _comparable(done.split(" ")) == _comparable(want)


def _comparable(argv):
    """A command as the report records it (argv joined by spaces), without
    the executable and --threads (which changes no byte)."""
    words = " ".join(argv[1:]).split(" ")
    return [w for k, w in enumerate(words) if w != "--threads" and (k == 0 or words[k - 1] != "--threads")]


def csv_cell(value):
    """A summary cell a spreadsheet shows as text: a leading =, +, -, @, tab or
    CR (a formula) gets a single quote first (OWASP's CSV-injection advice;
    the C++ tables use isoloft/core/sanitize.h's csv_cell, the same rule).
    The csv writer quotes what needs quoting."""
    text = str(value)
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def _write_summary(out, rows):
    path = pathlib.Path(out) / "summary.csv"
    tmp = path.with_name(f".summary.csv.tmp{os.getpid()}")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=SUMMARY_FIELDS, quoting=csv.QUOTE_MINIMAL)
        w.writeheader()
        for row in rows:
            # Names and errors are text; the numbers (exit code, seconds) stay numbers.
            w.writerow({k: csv_cell(v.replace("\0", "\\x00")) if isinstance(v, str) else v for k, v in row.items()})
    os.replace(tmp, path)


class _StopChildren:
    """While a batch runs (in the main thread): SIGTERM, SIGINT and SIGHUP
    stop the running CLI processes (each removes its temp files on SIGTERM),
    then the batch dies of the same signal."""

    SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)

    def __enter__(self):
        self.old = {}
        if threading.current_thread() is threading.main_thread():
            for s in self.SIGNALS:
                self.old[s] = signal.signal(s, self._stop)
        return self

    def __exit__(self, *exc):
        for s, h in self.old.items():
            signal.signal(s, h)

    def _stop(self, signum, frame):
        with _children_lock:
            _stopping.set()
            running = list(_children)
        for p in running:
            try:
                p.terminate()
            except OSError:
                pass
        for p in running:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
        self.__exit__()
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)


def batch(manifest, out, *, workers=None, scheduler=None, threads=1, format="ply", force=False, cli=None,
          on_case=None, z_slabs=1):
    """Runs every case of `manifest` as a task on Dask distributed: a local
    cluster of `workers` processes (default: the cores / threads), or the
    scheduler at `scheduler` (its workers must see the same paths and have
    isoloft installed). threads: --threads of each case (or slab). force: rerun
    cases already done. z_slabs: cut each case into that many z slabs, one
    task each, joined per object by a task after them. on_case(row) is called as each case ends. Returns the
    summary rows (also written to OUT/summary.csv), in manifest order."""
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    if workers is not None and scheduler is not None:
        raise ValueError("give either workers or scheduler, not both")
    cli = cli or default_cli()
    if not isinstance(z_slabs, int) or z_slabs < 1:
        raise ValueError(f"z_slabs: {z_slabs!r} is not a count of slabs (>= 1)")
    if format not in MESH_FORMATS:
        raise ValueError(f"format: unknown mesh format {format!r} (expected {', '.join(MESH_FORMATS)})")
    cases = read_manifest(manifest)  # before anything is written
    out = pathlib.Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    rows = {}
    todo = []
    for case in cases:
        if "error" in case:
            rows[case["name"]] = {"name": case["name"], "input": case["input"], "status": "failed",
                                  "exit_code": "", "seconds": 0.0, "error": case["error"]}
            if on_case:
                on_case(rows[case["name"]])
        elif not force and _is_done(case, out, cli, threads, format, z_slabs):
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
            # Dask's work space under --out, not in /tmp.
            with dask.config.set({**LOCAL_CLUSTER_CONFIG, "temporary-directory": str(out / DASK_DIR)}):
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=False, dashboard_address=None,
                                       local_directory=str(out / DASK_DIR))
        else:
            cluster = None
        try:
            with _StopChildren(), Client(cluster if cluster is not None else scheduler) as client:
                if z_slabs > 1:  # each case's slabs, then its join (Dask passes it the slabs' results)
                    futures = []
                    for c in todo:
                        parts = [client.submit(run_slab, c, str(out), cli, i, z_slabs, threads, pure=False,
                                               key=f"isoloft-{c['name']}-slab{i}") for i in range(1, z_slabs + 1)]
                        futures.append(client.submit(join_case, c, parts, str(out), cli, format, pure=False,
                                                     key=f"isoloft-{c['name']}-join"))
                else:
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
    parser.add_argument("--format", default="ply", choices=MESH_FORMATS,
                        help="mesh format of each case (default ply)")
    parser.add_argument("--force", action="store_true", help="rerun cases already done")
    parser.add_argument("--z-slabs", type=int, default=1,
                        help="cut each case into S z slabs (one task each), joined per object (default 1: whole)")
    parser.add_argument("--cli", help="the isoloft CLI to run (default: this package's)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no line per case")
    a = parser.parse_args(argv)
    if a.workers is not None and a.workers < 1:
        parser.error("--workers must be >= 1")
    if a.z_slabs < 1:
        parser.error("--z-slabs must be >= 1")

    from ._isoloft import _terminal_text as shown  # names reach the terminal escaped, as the CLI prints them

    def report(row):
        if not a.quiet:
            print(shown(f"isoloft batch: {row['name']}: {row['status']} ({row['seconds']} s)"
                        + (f": {row['error']}" if row["error"] else "")), file=sys.stderr)

    try:
        rows = batch(a.manifest, a.out, workers=a.workers, scheduler=a.scheduler, threads=a.threads,
                     format=a.format, force=a.force, cli=a.cli, on_case=report, z_slabs=a.z_slabs)
    except (OSError, ValueError) as e:
        print(shown(f"isoloft batch: error: {e}"), file=sys.stderr)
        return 1
    failed = sum(r["status"] == "failed" for r in rows)
    if not a.quiet:
        print(f"isoloft batch: {len(rows)} cases, {failed} failed, "
              f"{sum(r['status'] == 'skipped' for r in rows)} skipped; {pathlib.Path(a.out) / 'summary.csv'}",
              file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    # Run as the imported module, not __main__: Dask pickles the tasks by reference then
    # (functions of __main__ go by value, with the module's locks), and the stop signal reaches
    # the children the tasks started.
    from isoloft.cohort import main as module_main
    sys.exit(module_main())
