#!/usr/bin/env bash
# measure_codegen.sh BUILD_DIR [OUT.md]
#
# Cost of the generated code per benchmark model: jrgen generation time, size
# and lines of the generated .cpp, and the time and peak memory of compiling
# it alone with g++ (flags: $CODEGEN_CXXFLAGS, default -O2).  Writes a
# Markdown table to OUT.md (default BUILD_DIR/codegen/codegen.md) and stdout.
#
# BUILD_DIR is a configured and built jrgen tree (needs generator/jrgen and
# tests/make_random_model).  The random models are those of
# tests/bench/CMakeLists.txt (same make_random_model arguments).  Set
# CODEGEN_SKIP=tree10000 (a space-separated list) to leave models out, and
# CODEGEN_TIMEOUT (seconds, default 1800) to bound each compile; a compile
# that times out or runs out of memory (CODEGEN_MEM_KB, default 16000000) is
# reported as such.
set -euo pipefail

build=${1:?usage: measure_codegen.sh BUILD_DIR [OUT.md]}
build=$(cd "$build" && pwd)
src=$(cd "$(dirname "$0")/../.." && pwd)
out_dir="$build/codegen"
out=${2:-$out_dir/codegen.md}
cxx=${CXX:-g++}
flags=${CODEGEN_CXXFLAGS:--O2}
timeout_s=${CODEGEN_TIMEOUT:-1800}
mem_kb=${CODEGEN_MEM_KB:-16000000}
skip=" ${CODEGEN_SKIP:-} "
jrgen="$build/generator/jrgen"
mrm="$build/tests/make_random_model"
eigen_inc=$(pkg-config --cflags-only-I eigen3 2>/dev/null || echo -I/usr/include/eigen3)
mkdir -p "$out_dir"

# name | make_random_model arguments, or a path under models/
models=(
  "arm7|models/arm7.urdf"
  "legged30|models/legged30.urdf"
  "hmmwv14|models/hmmwv14.urdf"
  "tree100|tree --seed 101 --bodies 78 --max-depth 8"
  "tree1000|tree --seed 102 --bodies 710 --max-depth 8"
  "tree3000|tree --seed 105 --bodies 2140 --max-depth 8"
  "tree10000|tree --seed 103 --bodies 6850 --max-depth 8"
  "chain50|chain --seed 104 --bodies 50"
  "chain100|chain --seed 104 --bodies 100"
  "chain200|chain --seed 104 --bodies 200"
)

rows=()
for entry in "${models[@]}"; do
  name=${entry%%|*}
  spec=${entry#*|}
  [[ $skip == *" $name "* ]] && continue
  urdf="$out_dir/$name.urdf"
  if [[ $spec == models/* ]]; then
    cp "$src/$spec" "$urdf"
  else
    # shellcheck disable=SC2086
    "$mrm" $spec -o "$urdf"
  fi
  cpp="$out_dir/$name.cpp"
  /usr/bin/time -f "%e" -o "$out_dir/$name.gen.time" "$jrgen" "$urdf" -o "$cpp" --namespace "cg_$name"
  gen_s=$(cat "$out_dir/$name.gen.time")
  nv=$(grep -oE 'int nv = [0-9]+' "${cpp%.cpp}.hpp" | grep -oE '[0-9]+$')
  bytes=$(wc -c < "$cpp")
  lines=$(wc -l < "$cpp")
  echo "compiling $name (nv = $nv, $lines lines) with $cxx $flags ..." >&2
  set +e
  # shellcheck disable=SC2086
  (ulimit -v "$mem_kb"; /usr/bin/time -f "%e %U %M" -o "$out_dir/$name.cc.time" \
     timeout "$timeout_s" "$cxx" -std=c++20 $flags -I"$src/runtime/include" $eigen_inc \
     -c "$cpp" -o "$out_dir/$name.o" 2> "$out_dir/$name.cc.log")
  rc=$?
  set -e
  read -r wall user rss < <(tail -1 "$out_dir/$name.cc.time" | grep -E '^[0-9.]+ [0-9.]+ [0-9]+$' || echo "- - -")
  # A killed compiler's CPU time and memory are not reported through timeout.
  [[ $rc -eq 124 ]] && { wall=">$timeout_s"; user="-"; rss="-"; }
  if [[ $rc -eq 124 ]]; then status="timeout after ${timeout_s} s"
  elif [[ $rc -ne 0 ]]; then status="failed (rc $rc, see $name.cc.log)"
  else status="ok"; fi
  obj=$([[ -f "$out_dir/$name.o" && $rc -eq 0 ]] && wc -c < "$out_dir/$name.o" || echo -)
  rss_mb=$([[ $rss != - ]] && echo $((rss / 1024)) || echo -)
  rows+=("| $name | $nv | $gen_s | $((bytes / 1024)) | $lines | $wall | $user | $rss_mb | $obj | $status |")
done

{
  echo "Generated code per model: jrgen time, generated .cpp size, and compiling that file alone"
  echo "(\`$cxx -std=c++20 $flags -c\`, $($cxx --version | head -1))."
  echo
  echo "| model | nv | jrgen (s) | .cpp (KiB) | .cpp lines | compile wall (s) | compile user (s) | compile peak RSS (MiB) | .o (bytes) | status |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  printf '%s\n' "${rows[@]}"
} | tee "$out"
