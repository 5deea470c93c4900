#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer build and run of the generator
# and a subset of the tests (CI runs it after the test suite; docs/testing.md).
#
#   scripts/sanitize.sh
#
# build-asan: everything compiled with -fsanitize=address,undefined
# -fno-sanitize-recover=all (-DJRGEN_SANITIZE=ON), -O1 -g1, by clang++-14
# ($JRGEN_SANITIZE_CXX), with libFuzzer's coverage as well (-DJRGEN_FUZZ=ON):
# the same build then holds the fuzz target fuzz_urdf, and CI fuzzes with it
# (scripts/fuzz.sh with JRGEN_FUZZ_BUILD=build-asan) instead of compiling the
# generator once more for the fuzzer (docs/testing.md, "CI time").  With
# JRGEN_SANITIZE_CXX=g++ (GCC has no libFuzzer) the build has no fuzz target.
# It builds jrgen, which then generates the test solvers
# (so generation runs under the sanitizers too), and these test programs:
#   cli_test, golden_test        the instrumented jrgen on every CLI case,
#                                every tests/errors case and the goldens;
#   urdf_reader_test             the reader on its own;
#   runtime_test                 the runtime library against the reference;
#   generated_solver_test,       the generated solvers of JRGEN_TEST_SUBSET
#   generated_loops_test         below: trees (arm7, hmmwv14, stewart, a
#                                random 30-body tree, legged30 table-driven)
#                                and loops (HMMWV, Stewart, four-bar, random
#                                loops, table-driven Step 3);
#   fuzz_replay                  the fuzz target on its seeds and regressions.
# The programs run whole, two at a time (one process each: under ASan a
# process start costs seconds, and ctest would start one per test).  Any
# sanitizer finding aborts the program, so it fails, and so does this script;
# logs in build-asan/sanitize-logs/.  GeneratedRegistry.CoversEveryModelCase
# is left out: it checks the registry holds every model case, which a subset
# does not.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-asan
subset="gen_arm7;gen_hmmwv14;gen_stewart;gen_random_30_seed7;gen_legged30_tables124"
subset+=";gen_loops_hmmwv14;gen_loops_stewart;gen_loops_fourbar;gen_loops_random_9_seed3"
subset+=";gen_loops_hmmwv14_tables_ldlt"
tests=(cli_test runtime_test golden_test urdf_reader_test generated_solver_test generated_loops_test fuzz_replay)
# The longest, cli_test (an instrumented jrgen per test, ~250 s), runs as two
# GoogleTest shards, so that it does not end the stage alone on one core.
runs=(cli_test@0 cli_test@1 "${tests[@]:1}")
# The runtime sources these programs and jrgen link (CMakeLists.txt,
# JRGEN_RUNTIME_SUBSET): the others would be compiled for nothing.
runtime_subset="runtime;forces;constraint_solve"

# JRGEN_SELECTED_TARGETS: jrgen and the programs as one target, jrgen_selected,
# so that make -j2 compiles them side by side (CMakeLists.txt).
cxx=${JRGEN_SANITIZE_CXX:-clang++-14}
fuzz=OFF
selected="jrgen$(printf ';%s' "${tests[@]}")"
if [[ $("$cxx" --version) == *clang* ]]; then
  fuzz=ON
  selected+=";fuzz_urdf"
fi
cmake -S . -B "$build" -DCMAKE_CXX_COMPILER="$cxx" -DJRGEN_SANITIZE=ON -DJRGEN_FUZZ=$fuzz \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DJRGEN_TEST_SUBSET="$subset" \
  -DJRGEN_RUNTIME_SUBSET="$runtime_subset" -DJRGEN_SELECTED_TARGETS="$selected" >/dev/null
cmake --build "$build" -j2 --target jrgen_selected

export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=1:check_initialization_order=1:strict_init_order=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
mkdir -p "$build/sanitize-logs"
run_one() {  # run_one PROGRAM[@SHARD]: runs it (shard SHARD of 2), its output to a log; prints the verdict
  local t=${1%@*} shard=${1#*@} log="$build/sanitize-logs/${1/@/.shard}.log" start=$SECONDS
  local args=(--gtest_brief=1 --gtest_filter=-GeneratedRegistry.CoversEveryModelCase)
  [[ $t == fuzz_replay ]] && args=("$build/tests/fuzz/corpus" tests/fuzz/regressions)
  local env=()
  [[ $1 == *@* ]] && env=(GTEST_TOTAL_SHARDS=2 GTEST_SHARD_INDEX="$shard")
  if env "${env[@]}" "$build/tests/${t/fuzz_replay/fuzz/fuzz_replay}" "${args[@]}" >"$log" 2>&1; then
    echo "sanitize.sh: $t passed ($((SECONDS - start)) s)"
  else
    echo "sanitize.sh: $t FAILED ($log):"
    tail -n 60 "$log"
    return 1
  fi
}
export -f run_one
export build
printf '%s\n' "${runs[@]}" | xargs -P 2 -I{} bash -c 'run_one {}'
echo "sanitize.sh: no sanitizer finding"
