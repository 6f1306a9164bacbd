#!/usr/bin/python3
"""Issue 35's OReX benchmark: every method on OReX's Data/csl_with_ref shapes,
scored by experiments/orex_eval.py against the reference meshes.

Two section sets per shape:
  oblique  OReX's own CSL file (random planes; the shape's reference frame).
  ortho    PER_AXIS planes along each of x, y, z cut from the reference
           (experiments/orex_ortho.py make), the input ITK's
           MorphologicalContourInterpolator can take.
Methods (each a subprocess; wall seconds and peak resident memory from wait4):
  rbf      experiments/rbf_baseline.py (MITK kind, phi = r), both sets.
  mci      ITK MorphologicalContourInterpolator, axis = -1 (orex_ortho.py mci), ortho.
  isoloft  --isoloft 'CMD {csl} {out}': the command run per CSL file, both sets;
           {csl} is the input, {out} the mesh it must write (.ply).
Tune on eight_15, eight_20 and balloondog only (issue 35); hand, Elephant and
lamp004_fixed are reported, never tuned on.

Data (never committed): fetch haimsaw/OReX (the search tool's fetch gives a bare
git repository, e.g. /work/.mirror/haimsaw+OReX/repo) or git clone it; pass that
path as --orex (a checkout with Data/csl_with_ref/, or a bare repository, read
with git show).

usage: orex_bench.py --orex PATH --out DIR [--shapes a,b] [--methods rbf,mci,isoloft]
                     [--sets oblique,ortho] [--isoloft 'CMD {csl} {out}'] [--report]
Writes DIR/orex_bench.csv and DIR/orex_bench.md (per shape and set: Chamfer and
Hausdorff as % of the reference's bounding-box diagonal, components, genus, open (boundary) edges,
worst section distance on the input planes, seconds, peak MiB).
"""
import argparse
import csv
import os
import shlex
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import orex_eval as E  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
PY = "/usr/bin/python3"  # Debian's: numpy, scipy, vtk9
SHAPES = ["eight_15", "eight_20", "balloondog", "hand", "Elephant", "lamp004_fixed"]
TUNING = {"eight_15", "eight_20", "balloondog"}
FIELDS = ["shape", "set", "method", "status", "chamfer_pct", "hausdorff_pct", "components", "genus",
          "boundary_edges", "section_max_pct", "seconds", "peak_mib"]


def fetch_inputs(orex, shape, work):
    """(csl, reference) paths for a shape, from a checkout or a bare repository."""
    rel = ["Data/csl_with_ref/%s.csl" % shape, "Data/csl_with_ref/reference/%s_scaled.stl" % shape]
    if os.path.isdir(os.path.join(orex, "Data", "csl_with_ref")):
        paths = [os.path.join(orex, r) for r in rel]
    else:
        paths = []
        for r in rel:
            dst = os.path.join(work, os.path.basename(r))
            if not os.path.isfile(dst):
                blob = subprocess.run(["git", "-C", orex, "show", "HEAD:" + r], capture_output=True)
                if blob.returncode != 0:
                    raise ValueError("%s: no %s (%s)" % (orex, r, blob.stderr.decode().strip()))
                with open(dst, "wb") as f:
                    f.write(blob.stdout)
            paths.append(dst)
    for p in paths:
        if not os.path.isfile(p):
            raise ValueError("%s: missing" % p)
    return paths


def run(cmd, log):
    """Runs cmd under GNU time; (returncode, wall seconds, peak resident MiB of cmd and
    its children). Not os.wait4 on our own child: Linux keeps the forking
    process's high-water mark across exec, so a small method showed this
    script's own size (a `cp` read 161 MiB)."""
    peak_file = log + ".peak"
    t0 = time.perf_counter()
    with open(log, "w") as f:
        rc = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", peak_file] + cmd, stdout=f,
                            stderr=subprocess.STDOUT).returncode
    sec = time.perf_counter() - t0
    try:
        kib = float(open(peak_file).read().strip().splitlines()[-1])
    except (OSError, ValueError, IndexError):
        kib = float("nan")
    return rc, sec, kib / 1024.0


def method_command(method, csl, out, isoloft):
    if method == "rbf":
        return [PY, os.path.join(HERE, "rbf_baseline.py"), csl, out]
    if method == "mci":
        return [PY, os.path.join(HERE, "orex_ortho.py"), "mci", csl, out]
    if method == "isoloft":
        return [a.replace("{csl}", csl).replace("{out}", out) for a in shlex.split(isoloft)]
    raise ValueError("unknown method %s" % method)


def score(out, ref, csl):
    V, F = E.read_mesh(out)
    Vr, Fr = E.read_mesh(ref)
    ch, hd = E.chamfer_hausdorff(V, F, Vr, Fr)
    topo = E.topology(V, F)
    sec = E.section_check(V, F, E.read_csl(csl), E.bbox_diagonal(Vr))
    return {"chamfer_pct": 100 * ch, "hausdorff_pct": 100 * hd, "components": topo["components"],
            "genus": topo["genus"], "boundary_edges": topo["boundary_edges"],
            "section_max_pct": 100 * max(sec)}


def markdown(rows):
    lines = ["| shape | set | method | Chamfer % | Hausdorff % | comp. | genus | open edges | section max % | s | peak MiB |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if r["status"] != "ok":
            lines.append("| %s | %s | %s | %s | | | | | | %.1f | |" % (r["shape"], r["set"], r["method"], r["status"],
                                                                    r.get("seconds") or 0))
            continue
        lines.append("| %s%s | %s | %s | %.3f | %.3f | %d | %d | %d | %.3f | %.1f | %.0f |" % (
            r["shape"], "" if r["shape"] in TUNING else " (held out)", r["set"], r["method"],
            r["chamfer_pct"], r["hausdorff_pct"], r["components"], r["genus"], r["boundary_edges"],
            r["section_max_pct"],
            r["seconds"], r["peak_mib"]))
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--orex", required=True, help="OReX checkout or bare git repository")
    ap.add_argument("--out", required=True)
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument("--methods", default="rbf,mci,isoloft")
    ap.add_argument("--sets", default="oblique,ortho")
    ap.add_argument("--isoloft", help="command per CSL file, with {csl} and {out} (a .ply to write)")
    ap.add_argument("--report", action="store_true", help="only rewrite the markdown from the CSV")
    a = ap.parse_args()
    methods = a.methods.split(",")
    if "isoloft" in methods and not a.isoloft:
        methods.remove("isoloft")
        print("orex_bench: no --isoloft command; isoloft skipped")
    os.makedirs(a.out, exist_ok=True)
    work = os.path.join(a.out, "work")
    os.makedirs(work, exist_ok=True)
    csv_path = os.path.join(a.out, "orex_bench.csv")
    rows = []  # rows of earlier runs kept unless rerun here (isoloft can run later)
    if os.path.isfile(csv_path):
        with open(csv_path) as f:
            for r in csv.DictReader(f):
                for k in FIELDS[4:]:
                    r[k] = float(r[k]) if r[k] not in ("", None) else None
                rows.append(r)
    if a.report:
        with open(os.path.join(a.out, "orex_bench.md"), "w") as f:
            f.write(markdown(rows))
        return
    for shape in a.shapes.split(","):
        try:
            csl, ref = fetch_inputs(a.orex, shape, work)
        except ValueError as e:
            sys.exit("orex_bench: %s" % e)
        sets = {}
        for s in a.sets.split(","):
            if s == "oblique":
                sets[s] = csl
            elif s == "ortho":
                sets[s] = os.path.join(work, "%s_ortho.csl" % shape)
                rc, _, _ = run([PY, os.path.join(HERE, "orex_ortho.py"), "make", ref, sets[s]],
                               os.path.join(work, "%s_ortho_make.log" % shape))
                if rc != 0:
                    sys.exit("orex_bench: %s: making the orthogonal set failed (see %s)" % (shape, work))
            else:
                sys.exit("orex_bench: unknown set %s" % s)
        for s, path in sets.items():
            for m in methods:
                if m == "mci" and s != "ortho":
                    continue  # the filter takes axis-aligned slices only
                out = os.path.join(work, "%s_%s_%s.ply" % (shape, s, m))
                if os.path.exists(out):
                    os.remove(out)
                log = os.path.join(work, "%s_%s_%s.log" % (shape, s, m))
                rc, sec, mib = run(method_command(m, path, out, a.isoloft), log)
                row = {"shape": shape, "set": s, "method": m, "seconds": sec, "peak_mib": mib}
                if rc != 0 or not os.path.isfile(out):
                    row["status"] = "failed (rc %d)" % rc
                else:
                    try:
                        row.update(score(out, ref, path))
                        row["status"] = "ok"
                    except (ValueError, RuntimeError) as e:
                        row["status"] = "unscored: %s" % e
                rows = [r for r in rows if (r["shape"], r["set"], r["method"]) != (shape, s, m)] + [row]
                print("%-14s %-8s %-8s %s" % (shape, s, m, {k: (round(v, 4) if isinstance(v, float) else v)
                                                              for k, v in row.items() if k not in ("shape", "set", "method")}),
                      flush=True)
                rows.sort(key=lambda r: (SHAPES.index(r["shape"]) if r["shape"] in SHAPES else 99,
                                         r["set"], r["method"]))
                with open(csv_path, "w", newline="") as f:
                    w = csv.DictWriter(f, FIELDS, extrasaction="ignore")
                    w.writeheader()
                    w.writerows(rows)
                with open(os.path.join(a.out, "orex_bench.md"), "w") as f:
                    f.write(markdown(rows))


if __name__ == "__main__":
    main()
