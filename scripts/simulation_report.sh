#!/usr/bin/env bash
# The work-precision report of the published problems (docs/simulation.md,
# "Work-precision"; issue 21 item 3): builds published_work_precision in
# Release, runs it (integrators x tolerances on A01-A05, errors against each
# problem's reference, CPU time, forward-dynamics calls, energy and constraint
# drift) and draws OUT_DIR/wp_*.png, OUT_DIR/drift_*.png and
# OUT_DIR/work_precision.md with gnuplot.
#
#   scripts/simulation_report.sh [BUILD_DIR] [--quick] [-o OUT_DIR]
#
# BUILD_DIR defaults to build (configured Release with ccache when it has no
# CMakeCache.txt yet); OUT_DIR to BUILD_DIR/simulation_report.  --quick: three
# tolerances and short spans (seconds; the ctest published_work_precision runs
# the same with --check); the full sweep takes a few minutes of CPU.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="" quick="" out=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick="--quick" ;;
    -o) out="$2"; shift ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    -*) echo "simulation_report.sh: unknown option $1 (use [BUILD_DIR] [--quick] [-o OUT_DIR])" >&2; exit 2 ;;
    *) build="$1" ;;
  esac
  shift
done
build="${build:-$root/build}"
out="${out:-$build/simulation_report}"
command -v gnuplot >/dev/null || { echo "simulation_report.sh: gnuplot not found (Debian: apt-get install gnuplot-nox)" >&2; exit 1; }
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >/dev/null
fi
cmake --build "$build" -j"${JOBS:-2}" --target published_work_precision
mkdir -p "$out"
exe="$build/tests/published_work_precision"
"$exe" $quick -o "$out/runs.tsv" --series "$out/drift.tsv" 2> "$out/notes.txt" || {
  cat "$out/notes.txt" >&2; exit 1; }
commit="$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)"
header="Run $(date -u '+%Y-%m-%d %H:%M UTC') at commit $commit on $(nproc) cores of $(uname -m) \
(load average $(cut -d' ' -f1-3 /proc/loadavg)); CPU time is process time, median of repetitions${quick:+; --quick}."
python3 "$root/tests/published/simulation_report.py" --runs "$out/runs.tsv" --series "$out/drift.tsv" \
        --log "$out/notes.txt" --out "$out" --header "$header"
echo "simulation_report.sh: wrote $out/work_precision.md"
