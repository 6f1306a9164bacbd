#!/usr/bin/env bash
# Speed and memory (issue "Speed and memory"): per-stage times, max RSS and
# output hashes of the whole pipeline at the paper's jawbone and pelvis sizes
# with 1 and 2 threads (one process per configuration, so max RSS is its own),
# the scaling study (4x pixels per slice, 2x slices, single thread so that
# parallel efficiency does not blur it) and the stage micro-benchmarks.
# Writes experiments/out/bench/*.json and experiments/out/bench/summary.md.
#
# usage: scripts/bench.sh [extra bench_pipeline --end-to-end options]
# env:   RUNS (5), DECIMATE_ERROR (0.25 px), THREADS ("1 2"), MICRO (1: run the micro-benchmarks)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" --full
BIN="$ROOT/build/experiments/bench_pipeline"
OUT="$ROOT/experiments/out/bench"
mkdir -p "$OUT"
RUNS="${RUNS:-5}"
DECIMATE_ERROR="${DECIMATE_ERROR:-0.25}"
THREADS="${THREADS:-1 2}"
SCALING_THREADS=1

e2e() {  # name, then bench_pipeline options
  local name="$1"
  shift
  echo "bench: $name"
  "$BIN" --end-to-end --runs "$RUNS" --decimate-error "$DECIMATE_ERROR" --out "$OUT/$name.json" "$@"
}

for scale in jawbone pelvis; do
  for t in $THREADS; do e2e "${scale}_t$t" --scale "$scale" --threads "$t" "$@"; done
done
# Baseline of the scaling study: jawbone at SCALING_THREADS (reused if run above).
[[ " $THREADS " == *" $SCALING_THREADS "* ]] || e2e "jawbone_t$SCALING_THREADS" --scale jawbone --threads "$SCALING_THREADS" "$@"
e2e "scaling_size1000_t$SCALING_THREADS" --scale jawbone --size 1000 --threads "$SCALING_THREADS" "$@"
e2e "scaling_slices96_t$SCALING_THREADS" --scale jawbone --slices 96 --threads "$SCALING_THREADS" "$@"

if [[ "${MICRO:-1}" == 1 ]]; then
  echo "bench: micro-benchmarks"
  "$BIN" --benchmark_format=console --benchmark_out_format=json --benchmark_out="$OUT/micro.json"
fi

/usr/bin/python3 - "$OUT" "$SCALING_THREADS" "$(nproc)" "$(git -C "$ROOT" describe --always --dirty 2>/dev/null || echo unknown)" <<'EOF'
import json, os, sys

out, st, cores, version = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
min_timed_s = 1e-3  # a stage below 1 ms (e.g. decimation switched off) has no meaningful ratio
stages = ["contour", "mpu", "dist", "filter", "interp", "mesh", "decimate", "total", "wall"]

def load(name):
    path = os.path.join(out, name + ".json")
    return json.load(open(path)) if os.path.exists(path) else None

runs = {f[:-5]: load(f[:-5]) for f in sorted(os.listdir(out)) if f.endswith(".json") and f != "micro.json"}
lines = ["# Speed and memory", "",
         f"Made by `scripts/bench.sh` (`experiments/bench_pipeline.cpp`) on {cores} cores, isoloft {version}. "
         "Times are medians over the runs in seconds (stage times from `ReconstructResult::times`; "
         "`wall` also counts the mesh checks); max RSS is the whole process's (input stack included). "
         "Indicative only if the machine is shared.", "",
         "| run | scale | size | fit | slices | z | threads | " + " | ".join(stages) + " | max RSS MiB | triangles | hash |",
         "|" + "---|" * (len(stages) + 10)]
for name, d in runs.items():
    i = d["input"]
    tri = f'{d["triangles_before_decimation"]} → {d["triangles_after_decimation"]}'
    same = "" if d["mesh_hash_same_every_run"] else " (differs between runs!)"
    lines.append(f'| {name} | {d["scale"]} | {i["width"]}x{i["height"]} | {i["kind"]} @ {i["fit_raster_width"]} | {i["slices"]} | {i["z_spacing_px"]:g} | {d["threads"]} | '
                 + " | ".join(f'{d["median_s"][s]:.3f}' for s in stages)
                 + f' | {d["max_rss_mib"]:.0f} | {tri} | `{d["mesh_hash"]}`{same} |')

base = runs.get(f"jawbone_t{st}")
lines += ["", f"## Scaling (jawbone, {st} thread(s)): time ratio per stage", ""]
if base:
    lines += ["| ratio | " + " | ".join(stages) + " | max RSS |", "|" + "---|" * (len(stages) + 2)]
    for label, name in [("4x pixels per slice (1000 / 500 px)", f"scaling_size1000_t{st}"),
                        ("2x slices (96 / 48)", f"scaling_slices96_t{st}")]:
        d = runs.get(name)
        if d:
            r = [f'{d["median_s"][s] / base["median_s"][s]:.2f}' if base["median_s"][s] >= min_timed_s else "n/a" for s in stages]
            lines.append(f"| {label} | " + " | ".join(r)
                         + f' | {d["max_rss_mib"] / base["max_rss_mib"]:.2f} |')

lines += ["", "## Determinism across thread counts", ""]
for scale in ["jawbone", "pelvis"]:
    hashes = {d["threads"]: d["mesh_hash"] for n, d in runs.items() if n.startswith(scale + "_t")}
    verdict = "agree" if len(set(hashes.values())) == 1 else "DIFFER"
    lines.append(f"- {scale}: hashes {verdict} across threads " + ", ".join(f"{t}: `{h}`" for t, h in sorted(hashes.items())))

micro = load("micro")
if micro:
    lines += ["", "## Micro-benchmarks (one 500x500 jawbone slice; median real time)", "", "| benchmark | ms |", "|---|---|"]
    scale_to_ms = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}
    for b in micro["benchmarks"]:
        if b.get("aggregate_name") == "median":
            lines.append(f'| {b["run_name"].split("/")[0]} | {b["real_time"] * scale_to_ms[b["time_unit"]]:.3f} |')

path = os.path.join(out, "summary.md")
with open(path + ".tmp", "w") as f:
    f.write("\n".join(lines) + "\n")
os.replace(path + ".tmp", path)
print("bench: wrote", path)
EOF
