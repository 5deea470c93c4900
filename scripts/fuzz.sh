#!/usr/bin/env bash
# Fuzzes jrgen's URDF and cuts readers (and build_tree, analyze_constraints on
# what they accept) with libFuzzer for SECONDS seconds (default 60; CI runs 60).
#
#   scripts/fuzz.sh [SECONDS] [libFuzzer options...]
#   e.g. scripts/fuzz.sh 3600 -fork=2      (an hour, two processes)
#
# Builds build-fuzz (clang, -DJRGEN_FUZZ=ON: only the fuzz target and the
# libraries it needs, with ASan + UBSan; compiler: $JRGEN_FUZZ_CXX, default
# clang++-14), or with JRGEN_FUZZ_BUILD=DIR uses DIR, a build configured with
# the fuzz target already (CI: build-asan of scripts/sanitize.sh), then runs
# tests/fuzz/fuzz_urdf of that build on a working corpus in BUILD/fuzz-corpus
# (kept between runs; new inputs go there) and the seeds written from models/
# and tests/.  A crash, a hang (-timeout, 10 s per input), a leak or an
# out-of-memory is written to BUILD/fuzz-artifacts/ and the script exits
# non-zero.  Reproduce with
#   BUILD/tests/fuzz/fuzz_urdf BUILD/fuzz-artifacts/crash-...
# then turn it into a regression test (docs/testing.md).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
[[ $seconds =~ ^[0-9]+$ ]] || { echo "fuzz.sh: SECONDS must be a whole number, got '$seconds'" >&2; exit 2; }
build=${JRGEN_FUZZ_BUILD:-build-fuzz}
cxx=${JRGEN_FUZZ_CXX:-clang++-14}

if [[ $build == build-fuzz ]]; then
  # JRGEN_RUNTIME_SUBSET: the fuzz target links runtime.cpp alone of the runtime
  # (CMakeLists.txt); the other runtime files would be compiled for nothing.
  cmake -S . -B "$build" -DJRGEN_FUZZ=ON -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DJRGEN_RUNTIME_SUBSET=runtime >/dev/null
else
  # A build configured elsewhere with the fuzz target (CI: scripts/sanitize.sh's build-asan).
  grep -q '^JRGEN_FUZZ:BOOL=ON' "$build/CMakeCache.txt" 2>/dev/null ||
    { echo "fuzz.sh: JRGEN_FUZZ_BUILD=$build is not a build with -DJRGEN_FUZZ=ON" >&2; exit 2; }
fi
cmake --build "$build" -j2 --target fuzz_urdf
mkdir -p "$build/fuzz-corpus" "$build/fuzz-artifacts"
echo "fuzz.sh: fuzzing for ${seconds}s"
"$build/tests/fuzz/fuzz_urdf" \
  -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=16384 \
  -dict=tests/fuzz/urdf.dict -artifact_prefix="$build/fuzz-artifacts/" -print_final_stats=1 \
  "$@" "$build/fuzz-corpus" "$build/tests/fuzz/corpus"
echo "fuzz.sh: no crash, hang or leak in ${seconds}s"
