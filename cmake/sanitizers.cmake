# Sanitizer and fuzzing builds (docs/testing.md).  Each is a build folder of
# its own; the flags apply to everything compiled in it (runtime, generator,
# generated solvers, tests).
#
#   JRGEN_SANITIZE=ON  AddressSanitizer + UndefinedBehaviorSanitizer (GCC or
#                      Clang).  -fno-sanitize-recover=all makes every finding
#                      abort the program, so a test or a generation that hits
#                      one fails.  scripts/sanitize.sh builds and runs a subset.
#   JRGEN_FUZZ=ON      Clang only: the libFuzzer target tests/fuzz and just the
#                      libraries it needs, with coverage instrumentation and
#                      ASan + UBSan.  scripts/fuzz.sh builds and runs it.
#                      With JRGEN_SANITIZE=ON as well: the whole sanitizer
#                      build, every file with libFuzzer's coverage, and the
#                      fuzz target in it (scripts/sanitize.sh; CI then fuzzes
#                      with that build instead of compiling the generator a
#                      third time, docs/testing.md "CI time").
#   JRGEN_TSAN=ON      ThreadSanitizer, Clang only (with LLVM's libomp, whose
#                      OMPT tool Archer tells TSan about OpenMP's
#                      synchronization; GCC's libgomp is not instrumented and
#                      gives false reports).  scripts/tsan.sh builds and runs
#                      the threaded programs.
if(JRGEN_TSAN AND (JRGEN_SANITIZE OR JRGEN_FUZZ))
  message(FATAL_ERROR "JRGEN_TSAN is a build of its own: ThreadSanitizer cannot be combined with ASan")
endif()
if(JRGEN_TSAN)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "JRGEN_TSAN=ON needs Clang and libomp (-DCMAKE_CXX_COMPILER=clang++-14; Debian packages "
                        "clang-14 libomp-14-dev), not ${CMAKE_CXX_COMPILER_ID}: libgomp is not instrumented")
  endif()
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()

set(JRGEN_SANITIZER_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)

if(JRGEN_SANITIZE AND NOT JRGEN_FUZZ)
  add_compile_options(${JRGEN_SANITIZER_FLAGS})
  add_link_options(-fsanitize=address,undefined)
endif()

if(JRGEN_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "JRGEN_FUZZ=ON needs Clang with libFuzzer (-DCMAKE_CXX_COMPILER=clang++-14; "
                        "Debian packages clang-14 libclang-rt-14-dev), not ${CMAKE_CXX_COMPILER_ID}")
  endif()
  include(CheckCXXSourceCompiles)
  set(CMAKE_REQUIRED_LINK_OPTIONS -fsanitize=fuzzer)
  check_cxx_source_compiles(
    "#include <cstdint>\n#include <cstddef>\nextern \"C\" int LLVMFuzzerTestOneInput(const std::uint8_t*, std::size_t) { return 0; }"
    JRGEN_HAS_LIBFUZZER)
  unset(CMAKE_REQUIRED_LINK_OPTIONS)
  if(NOT JRGEN_HAS_LIBFUZZER)
    message(FATAL_ERROR "JRGEN_FUZZ=ON: ${CMAKE_CXX_COMPILER} cannot link -fsanitize=fuzzer (install libclang-rt-14-dev)")
  endif()
  # Coverage feedback for libFuzzer in every library; -fsanitize=fuzzer (its
  # main) is linked into the fuzz program alone (tests/fuzz/CMakeLists.txt).
  add_compile_options(-fsanitize=fuzzer-no-link ${JRGEN_SANITIZER_FLAGS})
  if(NOT JRGEN_SANITIZE)
    add_compile_options(-g)
  endif()
  add_link_options(-fsanitize=address,undefined)
endif()
