// The assembly through the jrgen binary (docs/assembly.md): the note on stderr,
// the report section, and --assemble-from with good and bad files.
// (The numerics are in tests/generator/assembly_test.cpp.)
#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include "cli/run_jrgen.hpp"

namespace jrgen::cli_testing {
namespace {

const fs::path kStretched = kSourceDir / "tests" / "assembly" / "fourbar_stretched.urdf";

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

int lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

// A four-bar drawn stretched (a singular configuration) assembles: one note
// on the assembly (which start, residuals, q), one on the dropped rows; the
// report ends with the configuration used.
TEST(CliAssembly, StretchedFourbarAssemblesWithANote) {
  ScratchDir scratch("jrgen_assembly");
  const RunResult r = run_jrgen({kStretched.string(), "-o", "solver.cpp", "--report", "OPS.md"}, scratch.path());
  SCOPED_TRACE(r.command);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(lines(r.err), 2) << r.err;
  const std::string note = split_lines(r.err).front();
  EXPECT_EQ(note.rfind("jrgen: note: " + kStretched.string() + ": the loops are open at the zero configuration "
                       "(largest residual 1.1, loop joint 'joint_D'); assembled from seeded start ",
                       0),
            0u)
      << note;
  EXPECT_TRUE(contains(note, "): q = ")) << note;
  const std::string report = slurp(scratch / "OPS.md");
  EXPECT_TRUE(contains(report, "\n## Assembly\n")) << report;
  for (const char* joint : {"| joint_A | ", "| joint_B | ", "| joint_C | "}) EXPECT_TRUE(contains(report, joint));
  EXPECT_TRUE(fs::exists(scratch / "solver.hpp"));
}

// The numbers of the note, given back with --assemble-from, are used as the start.
TEST(CliAssembly, AssembleFromTheNotedConfiguration) {
  ScratchDir scratch("jrgen_assembly");
  const RunResult first = run_jrgen({kStretched.string(), "-o", "a.cpp"}, scratch.path());
  ASSERT_EQ(first.status, 0) << first.err;
  const std::string note = split_lines(first.err).front();
  const std::size_t from = note.find("q = ") + 4, to = note.find(" (user order");
  ASSERT_NE(to, std::string::npos) << note;
  write_file(scratch / "q.txt", "# from the note\n" + note.substr(from, to - from) + "\n");
  const RunResult r =
      run_jrgen({kStretched.string(), "-o", "b.cpp", "--assemble-from", "q.txt"}, scratch.path());
  SCOPED_TRACE(r.command);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "assembled from the start in q.txt")) << r.err;
  // The same kept rows, so the same solver but for the header's name and
  // q_assembled: the four-bar has a one-dimensional set of assembled
  // configurations, and the iteration from the noted start (already within
  // kConverged = 1e-12 of it) stops a few 1e-10 along it (measured), so the
  // two agree to 1e-8, not to the bit.
  std::string a = slurp(scratch / "a.cpp"), b = slurp(scratch / "b.cpp");
  for (std::size_t at; (at = b.find("b.hpp")) != std::string::npos;) b.replace(at, 5, "a.hpp");
  const auto cut_q_assembled = [](std::string& text) {
    const std::size_t from = text.find("const double q_assembled[nq] = { ");
    const std::size_t to = text.find(" };\n", from);
    std::vector<double> q;
    std::istringstream numbers(text.substr(from + 34, to - from - 34));
    for (std::string x; std::getline(numbers, x, ',');) q.push_back(std::stod(x));
    text.erase(from, to - from);
    return q;
  };
  const std::vector<double> qa = cut_q_assembled(a), qb = cut_q_assembled(b);
  EXPECT_EQ(a, b);
  ASSERT_EQ(qa.size(), 3u);
  ASSERT_EQ(qb.size(), 3u);
  for (std::size_t i = 0; i < qa.size(); ++i) EXPECT_NEAR(qa[i], qb[i], 1e-8) << i;
}

// Bad start files: one error line naming the file (and line), nothing written.
TEST(CliAssembly, BadStartFileIsOneError) {
  const std::string give = "give nq = 3 numbers (user order: joint_A, joint_B, joint_C)";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"0.1 0.2\n", "q.txt: has 2 numbers; " + give},
      {"0.1,0.2\n0.3,0.4\n", "q.txt: has 4 numbers; " + give},
      {"0.1\n0.2 abc\n0.3\n", "q.txt:2: 'abc' is not a finite number; " + give},
  };
  for (const auto& [text, message] : cases) {
    ScratchDir scratch("jrgen_assembly");
    write_file(scratch / "q.txt", text);
    const RunResult r = run_jrgen({kStretched.string(), "-o", "solver.cpp", "--report", "OPS.md",
                                   "--assemble-from", "q.txt"},
                                  scratch.path());
    SCOPED_TRACE(r.command);
    EXPECT_EQ(r.status, 1);
    EXPECT_EQ(r.err, "jrgen: error: " + message + "\n");
    EXPECT_FALSE(fs::exists(scratch / "solver.cpp"));
    EXPECT_FALSE(fs::exists(scratch / "solver.hpp"));
    EXPECT_FALSE(fs::exists(scratch / "OPS.md"));
  }
  ScratchDir scratch("jrgen_assembly");
  const RunResult r = run_jrgen({kStretched.string(), "-o", "solver.cpp", "--assemble-from"}, scratch.path());
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err, "jrgen: error: --assemble-from: missing value; write --assemble-from Q.txt\n");
}

TEST(CliAssembly, HelpDocumentsAssembleFrom) {
  ScratchDir scratch("jrgen_assembly");
  const RunResult r = run_jrgen({"--help"}, scratch.path());
  ASSERT_EQ(r.status, 0);
  EXPECT_TRUE(contains(r.out, "[--assemble-from Q.txt]")) << r.out;
  EXPECT_TRUE(contains(r.out, "  --assemble-from Q.txt start the assembly")) << r.out;
  EXPECT_TRUE(contains(r.out, "docs/assembly.md")) << r.out;
}

}  // namespace
}  // namespace jrgen::cli_testing
