#!/usr/bin/env bash
# Builds the libFuzzer targets (sanitize_build.sh: clang-14, ASan + UBSan) in build-asan/
# and runs each for SECONDS seconds (default 60) from the committed corpus
# (fuzz/corpus/<target>/, read only; new inputs go to build-asan/corpus/).
# Crashes are left as build-asan/crash-*: add each to fuzz/corpus/<target>/
# once fixed, and the replay test (fuzz_corpus_replay) keeps it fixed.
#   fuzz.sh [SECONDS] [TARGET...]   targets: png polylines params nifti nrrd metaimage rtstruct roi_names label_names csl manifest
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECS="${1:-60}"; shift || true
TARGETS=("$@")
GOALS=("${TARGETS[@]/#/fuzz_}")
# All of them: one goal (make builds the goals of one call one at a time).
((${#TARGETS[@]})) || { TARGETS=(png polylines params nifti nrrd metaimage rtstruct roi_names label_names csl manifest); GOALS=(isoloft_fuzzers); }
for p in clang-14 libclang-rt-14-dev lld-14; do  # as setup.sh --full installs them
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$p"; }
done
B="$ROOT/build-asan"
"$ROOT/scripts/sanitize_build.sh" "${GOALS[@]}"
cd "$B"
# Targets run side by side, one per core (each fuzzer is one process).
JOBS="${ISOLOFT_JOBS:-$(nproc)}"
fuzz_one() {
  local t=$1
  mkdir -p "corpus/$t"
  # 2 GB RSS and 10 s per input: a larger or slower one is a finding too.
  ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS="suppressions=$ROOT/scripts/lsan.supp" "./fuzz/fuzz_$t" -max_total_time="$SECS" \
    -rss_limit_mb=2048 -timeout=10 -max_len=65536 -artifact_prefix="$B/crash-$t-" "corpus/$t" "$ROOT/fuzz/corpus/$t" \
    > "fuzz-$t.log" 2>&1
}
declare -A pid_of
status=0
for t in "${TARGETS[@]}"; do
  while (($(jobs -rp | wc -l) >= JOBS)); do wait -n || true; done
  echo "fuzz: $t for $SECS s"
  fuzz_one "$t" &
  pid_of[$t]=$!
done
for t in "${TARGETS[@]}"; do
  wait "${pid_of[$t]}" || { status=1; echo "fuzz: $t FAILED"; }
  echo "fuzz: $t: $(grep -E '^Done [0-9]+ runs' "fuzz-$t.log" || tail -n 3 "fuzz-$t.log")"
done
ls "$B"/crash-* 2>/dev/null && status=1
exit $status
