// The main() of every GoogleTest program of the suite (tests/CMakeLists.txt,
// jrgen_test()): GoogleTest's, plus one rule for ctest.  ctest runs each test
// suite (all tests of one Suite.*) in one process (tests/discover_suites.cmake),
// so a skipped test cannot be reported by ctest's own test-by-test skip
// pattern without hiding its passing neighbours.  With JRGEN_TEST_SKIP_CODE
// set (ctest sets it, with the same SKIP_RETURN_CODE), a run in which no test
// failed but at least one was skipped exits with that code: ctest reports the
// suite as skipped, and CI's skip gate (.ci/check_skips) sees it.  A failure
// always exits 1.
#include <gtest/gtest.h>

#include <cstdlib>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  const int result = RUN_ALL_TESTS();
  const char* skip_code = std::getenv("JRGEN_TEST_SKIP_CODE");
  if (result == 0 && skip_code != nullptr && ::testing::UnitTest::GetInstance()->skipped_test_count() > 0) {
    return std::atoi(skip_code);
  }
  return result;
}
