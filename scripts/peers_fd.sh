#!/usr/bin/env bash
# jrgen's forward_dynamics against MuJoCo's mj_forward (and Pinocchio's aba
# and crba+nle+cholesky when given its source), one process per model pinned
# to one CPU (tests/peers, docs/benchmarks.md).  Builds in Release (-O3,
# portable unless --native) and prints the markdown table.
#
#   scripts/peers_fd.sh [BUILD_DIR] [--pinocchio SRC] [--cpu N] [--native] [--quick]
#                       [--no-dispatch] [--models "arm7 panda ..."] [-o OUT_DIR]
#
# BUILD_DIR defaults to build-peers, OUT_DIR to BUILD_DIR/peers (one JSON,
# log and error file per model, and table.md).  --cpu N (default 1): the CPU
# every program is pinned to with taskset.  --pinocchio SRC: an extracted
# source tree of stack-of-tasks/pinocchio, compiled header-only into the
# programs (nothing of it is copied into the repository).  --quick: short
# timings, for a smoke run.  --no-dispatch: jrgen's solvers in one copy, the
# baseline x86-64 code (JRGEN_DISPATCH OFF); by default they are built as
# add_jr_solver() builds them, with the x86-64-v3 copy the loader picks on
# processors with AVX2 and FMA (docs/specialization.md).  JOBS=N: parallel
# compile jobs (default 2).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="" out="" cpu=1 native=OFF quick="" pin="" models="" dispatch=ON
while [ $# -gt 0 ]; do
  case "$1" in
    --pinocchio) pin="$(cd "$2" && pwd)"; shift ;;
    --cpu) cpu="$2"; shift ;;
    --native) native=ON ;;
    --quick) quick="--quick" ;;
    --no-dispatch) dispatch=OFF ;;
    --models) models="$2"; shift ;;
    -o) out="$2"; shift ;;
    -h|--help) sed -n '2,19p' "$0"; exit 0 ;;
    -*) echo "peers_fd.sh: unknown option $1" >&2; exit 2 ;;
    *) build="$1" ;;
  esac
  shift
done
build="${build:-$root/build-peers}"
mkdir -p "$build" && build="$(cd "$build" && pwd)"
out="${out:-$build/peers}"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O3 -DNDEBUG" \
      -DJRGEN_NATIVE="$native" -DJRGEN_DISPATCH="$dispatch" -DJRGEN_BUILD_PEERS=ON -DJRGEN_PINOCCHIO_SOURCE="$pin" "${launcher[@]}" >/dev/null
programs="$build/tests/peers/peers_programs.tsv"
if [ -n "$models" ]; then
  targets=(); for m in $models; do targets+=("peers_fd_$m"); done
else
  targets=(jrgen_peers)
fi
cmake --build "$build" -j"${JOBS:-2}" --target "${targets[@]}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"  # the programs run from inside it
pin_cmd=()
command -v taskset >/dev/null && pin_cmd=(taskset -c "$cpu")
jsons=()
while IFS=$'\t' read -r name prog; do
  [ -z "$name" ] && continue
  if [ -n "$models" ] && [[ " $models " != *" $name "* ]]; then continue; fi
  echo "peers_fd: $name" >&2
  status=0
  (cd "$out" && "${pin_cmd[@]}" "$prog" $quick --benchmark_out="$out/$name.json" --benchmark_out_format=json \
       >"$out/$name.log" 2>"$out/$name.err") || status=$?
  cat "$out/$name.err" >&2
  [ "$status" -ne 0 ] && echo "peers_fd: $name exited with $status" >&2
  jsons+=("$out/$name.json")
done <"$programs"
{
  echo "$(date -u '+%Y-%m-%d %H:%M UTC'); $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown);" \
       "$(lscpu | sed -n 's/^Model name: *//p' | head -1); load average $(cut -d' ' -f1-3 /proc/loadavg);" \
       "pinned to CPU $cpu; JRGEN_NATIVE=$native."
  echo
  python3 "$root/tests/peers/format_peers.py" "${jsons[@]}"
} | tee "$out/table.md"
