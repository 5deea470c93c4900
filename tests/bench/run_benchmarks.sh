#!/usr/bin/env bash
# run_benchmarks.sh [BUILD_DIR]
#
# Configures BUILD_DIR (default /tmp/bench_build) as a Release build of the
# jrgen tree this script belongs to with -DJRGEN_BUILD_BENCHMARKS=ON, builds
# the benchmark programs only, runs each (5 repetitions, aggregates only,
# pinned to one core with taskset when available) and writes
# BUILD_DIR/bench_results/benchmarks.md: machine, compiler, flags, date,
# commit and the tables of docs/benchmarks.md.
#
# Environment: JRGEN_BENCH_TREE10000=OFF leaves out the ~10000-dof tree (built
# by default: table-driven, it compiles in seconds); JRGEN_BENCH_SOLVER_FLAGS (e.g. -O1) extra
# flags for the generated solvers only; BENCH_PROGRAMS (space-separated, e.g.
# "bench_tree1000 bench_tree10000") a subset of the programs; JOBS (default 1)
# parallel build jobs; BENCH_CPU (default 1) the core to pin to; BENCH_TIME
# (cpu_time or real_time, default cpu_time) the time reported; JRGEN_COMMIT
# overrides the commit recorded (for a source tree that is not a git checkout); further
# arguments after BUILD_DIR go to every benchmark program.
set -euo pipefail

src=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-/tmp/bench_build}
shift || true
jobs=${JOBS:-1}
cpu=${BENCH_CPU:-1}
mkdir -p "$build"
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DJRGEN_BUILD_BENCHMARKS=ON \
      -DJRGEN_BENCH_TREE10000="${JRGEN_BENCH_TREE10000:-ON}" \
      -DJRGEN_BENCH_PARALLEL="${JRGEN_BENCH_PARALLEL:-OFF}" \
      -DJRGEN_BENCH_SOLVER_FLAGS="${JRGEN_BENCH_SOLVER_FLAGS:-}" > "$build/bench_configure.log"
# The programs of tests/bench/CMakeLists.txt's jrgen_bench() (other benchmark
# programs in the folder have their own scripts).
mapfile -t programs < "$build/tests/bench/bench_programs.txt"
[[ -n ${BENCH_PROGRAMS:-} ]] && read -r -a programs <<< "$BENCH_PROGRAMS"
cmake --build "$build" -j "$jobs" --target "${programs[@]}"

results="$build/bench_results"
rm -rf "$results"
mkdir -p "$results/json"
pin=()
command -v taskset > /dev/null && pin=(taskset -c "$cpu")
for program in "${programs[@]}"; do
  [[ -n $program ]] || continue
  exe="$build/tests/bench/$program"
  name=${program#bench_}
  echo "== $name" >&2
  run_pin=("${pin[@]}")
  [[ $name == ptree* ]] && run_pin=()
  "${run_pin[@]}" "$exe" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
      --benchmark_out="$results/json/$name.json" --benchmark_out_format=json "$@" \
      | tee "$results/$name.txt"
done

flags=$(grep -E '^CMAKE_CXX_FLAGS(_RELEASE)?:' "$build/CMakeCache.txt" | sed 's/:STRING=/ = /' | tr '\n' ';')
commit=${JRGEN_COMMIT:-$(git -C "$src" rev-parse --short HEAD 2> /dev/null || echo unknown)}
dirty=$(git -C "$src" status --porcelain 2> /dev/null | grep -qv '^??' && echo " (working tree modified)" || true)
{
  echo "- date: $(date -u +%Y-%m-%dT%H:%MZ)"
  echo "- commit: $commit$dirty"
  echo "- machine: $(lscpu | sed -n 's/^Model name:[[:space:]]*//p' | head -1), $(nproc) cores; load average before the runs: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "- compiler: $(${CXX:-g++} --version | head -1)"
  echo "- flags: ${flags%;} (CMake Release); generated solvers: the same${JRGEN_BENCH_SOLVER_FLAGS:+ followed by $JRGEN_BENCH_SOLVER_FLAGS}"
  echo "- Google Benchmark $(dpkg-query -W -f='${Version}' libbenchmark-dev 2> /dev/null || echo '?'), Eigen $(pkg-config --modversion eigen3 2> /dev/null || echo '?')"
  echo "- pinned: ${pin[*]:-no}"
  echo
  python3 "$src/tests/bench/format_results.py" "$results/json" "$build/tests/bench/ops" "${BENCH_TIME:-cpu_time}"
} > "$results/benchmarks.md"
cat "$results/benchmarks.md"
