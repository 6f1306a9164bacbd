#!/usr/bin/env bash
# Builds the libFuzzer targets with clang-14 (ASan + UBSan) into build-fuzz/
# and runs each for SECONDS seconds (default 60) from the committed corpus
# (fuzz/corpus/<target>/, read only; new inputs go to build-fuzz/corpus/).
# Crashes are left as build-fuzz/crash-*: add each to fuzz/corpus/<target>/
# once fixed, and the replay test (fuzz_corpus_replay) keeps it fixed.
#   fuzz.sh [SECONDS] [TARGET...]   targets: png polylines params nifti nrrd metaimage rtstruct
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECS="${1:-60}"; shift || true
TARGETS=("$@")
((${#TARGETS[@]})) || TARGETS=(png polylines params nifti nrrd metaimage rtstruct)
missing=()
for p in clang-14 libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"; fi
B="$ROOT/build-fuzz"
cmake -S "$ROOT" -B "$B" -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DISOLOFT_BUILD_FUZZERS=ON -DISOLOFT_BUILD_TESTS=OFF -DISOLOFT_BUILD_VALIDATION=OFF -DISOLOFT_BUILD_EXPERIMENTS=OFF \
  > "$B.log" 2>&1 || { cat "$B.log"; exit 1; }
cmake --build "$B" -j "${ISOLOFT_JOBS:-$(nproc)}" --target "${TARGETS[@]/#/fuzz_}" >> "$B.log" 2>&1 || { tail -n 60 "$B.log"; exit 1; }
cd "$B"
status=0
for t in "${TARGETS[@]}"; do
  mkdir -p "corpus/$t"
  echo "fuzz: $t for $SECS s"
  # 2 GB RSS and 10 s per input: a larger or slower one is a finding too.
  ASAN_OPTIONS=detect_leaks=1 "./fuzz/fuzz_$t" -max_total_time="$SECS" -rss_limit_mb=2048 -timeout=10 \
    -max_len=65536 -artifact_prefix="$B/crash-$t-" "corpus/$t" "$ROOT/fuzz/corpus/$t" 2>&1 | tail -n 4 || status=1
done
ls "$B"/crash-* 2>/dev/null && status=1
exit $status
