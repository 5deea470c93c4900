#!/usr/bin/env bash
# The solver report (docs/report.md): builds what it needs in Release (-O3)
# and writes BUILD_DIR/report/report.md with its plots, including the full
# forward-dynamics table (forward_dynamics against MuJoCo's mj_forward, each
# qdd against the independent reference; scripts/peers_fd.sh does the same
# on the real robots' URDFs, with Pinocchio optional).
#
#   scripts/report.sh [BUILD_DIR] [--quick | --full] [--native] [-o OUT_DIR]
#
# BUILD_DIR defaults to build-report.  The default set (tests/report/models.txt)
# reaches about 1000 dofs; --full adds larger models (slow to compile), --quick
# is the small set CI runs.  --native compiles everything, the Eigen peers
# included, for this machine's processor (-DJRGEN_NATIVE=ON, -march=native);
# without it the build is portable (SSE2 on x86-64).  REPORT_CPU=N pins every
# program to CPU N.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="" set="default" quick="" out="" native="OFF"
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) set="quick"; quick="--quick" ;;
    --full) set="full" ;;
    --native) native="ON" ;;
    -o) out="$2"; shift ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    -*) echo "report.sh: unknown option $1" >&2; exit 2 ;;
    *) build="$1" ;;
  esac
  shift
done
build="${build:-$root/build-report}"
out="${out:-$build/report}"
jobs="${JOBS:-2}"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O3 -DNDEBUG" \
      -DJRGEN_REPORT_SET="$set" -DJRGEN_NATIVE="$native" >/dev/null
cmake --build "$build" -j"$jobs" --target jrgen_report_programs
python3 "$root/tests/report/run_report.py" --programs "$build/tests/report/report_programs.tsv" \
        --out "$out" --set "$set" $quick
