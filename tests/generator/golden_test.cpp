// Golden regression of the emitted solver (docs/conventions.md, "Tests").
//
// Each folder tests/golden/<case>/ holds
//   args        one line: the model (a file in models/), then jrgen options;
//               a --cuts file is also named relative to models/;
//   solver.cpp  the expected output of `jrgen <model> <options> -o solver.cpp`
//   solver.hpp  (a fixed output name keeps the banner and #include stable).
// The test regenerates every case with the real jrgen and compares bytes,
// printing the first differing line; the actual files are left in
// <build>/tests/golden_actual/<case>/ for a full diff.
//
// Refreshing, after an intended change of the emitter:
//   make update_goldens        (runs this test with JRGEN_UPDATE_GOLDENS=1,
//                               which writes the outputs into the source tree)
//   git diff tests/golden      review, then commit with the emitter change.
// A new case is a new folder with an args file, then `make update_goldens`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/run_jrgen.hpp"

#ifndef JRGEN_BINARY_DIR
#error "JRGEN_BINARY_DIR must be defined (absolute path of the build tree)"
#endif

namespace jrgen::cli_testing {
namespace {

const std::vector<std::string> kOutputs = {"solver.cpp", "solver.hpp"};

bool update_mode() {
  const char* v = std::getenv("JRGEN_UPDATE_GOLDENS");
  return v && *v && std::string(v) != "0";
}

std::vector<std::string> golden_cases() {
  std::vector<std::string> cases;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(kGoldenDir, ec))
    if (entry.is_directory()) cases.push_back(entry.path().filename().string());
  std::sort(cases.begin(), cases.end());
  return cases;
}

// The jrgen arguments of a case, input files made absolute.
std::vector<std::string> case_arguments(const std::string& name) {
  std::istringstream in(slurp(kGoldenDir / name / "args"));
  std::vector<std::string> tokens;
  for (std::string t; in >> t;) tokens.push_back(t);
  if (tokens.empty()) throw std::runtime_error("tests/golden/" + name + "/args is empty");
  tokens[0] = (kModelsDir / tokens[0]).string();
  for (std::size_t i = 1; i + 1 < tokens.size(); ++i)
    if (tokens[i] == "--cuts") tokens[i + 1] = (kModelsDir / tokens[i + 1]).string();
  return tokens;
}

class Golden : public ::testing::TestWithParam<std::string> {};

TEST_P(Golden, MatchesGeneratedCode) {
  const std::string name = GetParam();
  const fs::path dir = kGoldenDir / name;
  ASSERT_TRUE(fs::exists(dir / "args")) << dir << " has no args file";
  std::vector<std::string> args = case_arguments(name);
  args.insert(args.end(), {"-o", "solver.cpp"});

  ScratchDir scratch("jrgen_golden");
  const RunResult r = run_jrgen(args, scratch.path());
  ASSERT_EQ(r.status, 0) << r.command << "\n" << r.err;
  // Notes (dropped redundant rows, --divide's reciprocal steps) are fine;
  // nothing else may reach stderr.
  std::istringstream err(r.err);
  for (std::string line; std::getline(err, line);)
    EXPECT_EQ(line.rfind("jrgen: note: ", 0), 0u) << r.command << "\n" << line;

  if (update_mode()) {
    for (const std::string& file : kOutputs) {
      const std::string actual = slurp(scratch / file);
      const bool same = fs::exists(dir / file) && slurp(dir / file) == actual;
      if (!same) write_file(dir / file, actual);
      std::cout << "tests/golden/" << name << "/" << file << (same ? ": unchanged" : ": UPDATED") << "\n";
    }
    return;
  }

  const fs::path actual_dir = fs::path(JRGEN_BINARY_DIR) / "tests" / "golden_actual" / name;
  for (const std::string& file : kOutputs) {
    SCOPED_TRACE("tests/golden/" + name + "/" + file);
    const std::string actual = slurp(scratch / file);
    if (!fs::exists(dir / file)) {
      ADD_FAILURE() << "missing golden file; run `make update_goldens` and review the result";
      continue;
    }
    const std::string diff = first_difference(slurp(dir / file), actual);
    if (diff.empty()) continue;
    fs::create_directories(actual_dir);
    write_file(actual_dir / file, actual);
    ADD_FAILURE() << "generated code differs from the golden file (" << r.command << ")\n"
                  << diff << "\nfull diff: diff -u " << (dir / file).string() << " " << (actual_dir / file).string()
                  << "\nif the change is intended: make update_goldens, then review git diff tests/golden";
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, Golden, ::testing::ValuesIn(golden_cases()),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

// The cases docs/conventions.md, "Tests" and the test plan call for, each complete.
TEST(GoldenSetup, RequiredCasesArePresent) {
  const std::vector<std::string> cases = golden_cases();
  for (const char* required : {"arm7", "arm7_ldlt", "hmmwv14", "legged30"})
    EXPECT_NE(std::find(cases.begin(), cases.end(), required), cases.end()) << "tests/golden/" << required;
  for (const std::string& c : cases) {
    SCOPED_TRACE("tests/golden/" + c);
    EXPECT_TRUE(fs::exists(kGoldenDir / c / "args"));
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(kGoldenDir / c)) files.push_back(entry.path().filename().string());
    std::sort(files.begin(), files.end());
    EXPECT_EQ(files, (std::vector<std::string>{"args", "solver.cpp", "solver.hpp"}));
    if (c.find("ldlt") != std::string::npos) {
      EXPECT_NE(slurp(kGoldenDir / c / "args").find("--method ldlt"), std::string::npos);
    }
  }
}

// The arm7 goldens differ only where the method does.
TEST(GoldenSetup, LltAndLdltGoldensDiffer) {
  ASSERT_TRUE(fs::exists(kGoldenDir / "arm7" / "solver.cpp")) << "missing golden: make update_goldens";
  ASSERT_TRUE(fs::exists(kGoldenDir / "arm7_ldlt" / "solver.cpp")) << "missing golden: make update_goldens";
  EXPECT_NE(slurp(kGoldenDir / "arm7" / "solver.cpp"), slurp(kGoldenDir / "arm7_ldlt" / "solver.cpp"));
}

}  // namespace
}  // namespace jrgen::cli_testing
