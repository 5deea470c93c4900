#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer build and run of the generator
# and a subset of the tests (CI runs it after the test suite; docs/testing.md).
#
#   scripts/sanitize.sh
#
# build-asan: everything compiled with -fsanitize=address,undefined
# -fno-sanitize-recover=all (-DJRGEN_SANITIZE=ON), -O1 -g1, by the default
# compiler (g++).  It builds jrgen, which then generates the test solvers
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
# The runtime sources these programs and jrgen link (CMakeLists.txt,
# JRGEN_RUNTIME_SUBSET): the others would be compiled for nothing.
runtime_subset="runtime;forces;constraint_solve"

# JRGEN_SELECTED_TARGETS: jrgen and the programs as one target, jrgen_selected,
# so that make -j2 compiles them side by side (CMakeLists.txt).
selected="jrgen$(printf ';%s' "${tests[@]}")"
cmake -S . -B "$build" -DJRGEN_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DJRGEN_TEST_SUBSET="$subset" \
  -DJRGEN_RUNTIME_SUBSET="$runtime_subset" -DJRGEN_SELECTED_TARGETS="$selected" >/dev/null
cmake --build "$build" -j2 --target jrgen_selected

export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=1:check_initialization_order=1:strict_init_order=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
mkdir -p "$build/sanitize-logs"
run_one() {  # run_one PROGRAM: runs it, its output to a log; prints the verdict
  local t=$1 log="$build/sanitize-logs/$1.log" start=$SECONDS
  local args=(--gtest_brief=1 --gtest_filter=-GeneratedRegistry.CoversEveryModelCase)
  [[ $t == fuzz_replay ]] && args=("$build/tests/fuzz/corpus" tests/fuzz/regressions)
  if "$build/tests/${t/fuzz_replay/fuzz/fuzz_replay}" "${args[@]}" >"$log" 2>&1; then
    echo "sanitize.sh: $t passed ($((SECONDS - start)) s)"
  else
    echo "sanitize.sh: $t FAILED ($log):"
    tail -n 60 "$log"
    return 1
  fi
}
export -f run_one
export build
printf '%s\n' "${tests[@]}" | xargs -P 2 -I{} bash -c 'run_one {}'
echo "sanitize.sh: no sanitizer finding"
