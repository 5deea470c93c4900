// Tests of the jrgen command line (docs/interface.md section 1; docs/conventions.md, "Errors"),
// run on the real binary (JRGEN_EXECUTABLE) through fork/exec:
//   CliErrors       every bad input: exit status 1, exactly one line on stderr
//                   naming the file (and line) and what is wrong, nothing on
//                   stdout, and no output file created or modified;
//   CliErrorFolder  the same for every case in tests/errors/ (.urdf directly,
//                   .cuts.xml with --cuts on tests/cli/cuts_base.urdf);
//   CliInfo         --help and --version;
//   CliOutput       what a successful run writes;
//   CliDeterminism  every model in models/ generated twice from different
//                   folders and path spellings gives the same bytes, with no
//                   paths, dates or host names in the output;
//   CliReport       --report: the table's shape, Total = sum of the steps,
//                   every count of Steps 1, 2, 4 recounted from the emitted
//                   code, and the 1- and 2-DOF pendulums derived by hand.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <map>
#include <ostream>
#include <regex>
#include <string>
#include <vector>

#include "cli/run_jrgen.hpp"

#ifndef JRGEN_BINARY_DIR
#error "JRGEN_BINARY_DIR must be defined (absolute path of the build tree)"
#endif

namespace jrgen::cli_testing {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string trim_newlines(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  return s;
}

// ===========================================================================
// Errors
// ===========================================================================

// A bad-input run.  `args` may use @OUT@ (the output folder, where -o and
// --report point) and @CWD@ (the folder jrgen runs in; fresh and empty unless
// `prepare` puts something there).
struct BadRun {
  std::vector<std::string> args;
  std::vector<std::string> expected;  // substrings the one stderr line must contain
  // Builds files or folders in the output folder (and cwd) before the run.
  std::function<void(const fs::path& out, const fs::path& cwd)> prepare;
  // A folder under the output folder that jrgen must find read-only: when the
  // test runs as root (whom permissions do not stop), a read-only bind mount
  // of it in jrgen's own mount namespace (run_jrgen).
  std::string read_only = {};
};

std::vector<std::string> substitute(const std::vector<std::string>& args, const fs::path& out,
                                    const fs::path& cwd) {
  std::vector<std::string> result;
  for (std::string a : args) {
    for (const auto& [key, value] : {std::pair<std::string, std::string>{"@OUT@", out.string()},
                                     std::pair<std::string, std::string>{"@CWD@", cwd.string()}}) {
      for (std::size_t p = a.find(key); p != std::string::npos; p = a.find(key, p + value.size()))
        a.replace(p, key.size(), value);
    }
    result.push_back(a);
  }
  return result;
}

// The output files a run may touch; pre-created (when `prepare` has not put
// something there already) to check a failing run leaves them byte-identical.
const std::array<const char*, 5> kPreexisting = {"solver.cpp", "solver.hpp", "OPS.md", "other.cpp",
                                                 "other.hpp"};

void check_one_failure(const BadRun& bad, bool with_preexisting_outputs) {
  SCOPED_TRACE(with_preexisting_outputs ? "output folder holds earlier outputs"
                                        : "output folder empty");
  ScratchDir scratch("jrgen_cli");
  const fs::path out = scratch / "out";
  const fs::path cwd = scratch / "cwd";
  fs::create_directories(out);
  fs::create_directories(cwd);
  if (bad.prepare) bad.prepare(out, cwd);
  if (with_preexisting_outputs)
    for (const char* name : kPreexisting)
      if (!fs::exists(out / name)) write_file(out / name, std::string("earlier ") + name + "\n");

  const Snapshot out_before = snapshot(out);
  const Snapshot cwd_before = snapshot(cwd);
  const bool mount_ro = !bad.read_only.empty() && ::geteuid() == 0;
  const RunResult r = run_jrgen(substitute(bad.args, out, cwd), cwd, mount_ro ? out / bad.read_only : fs::path());
  SCOPED_TRACE(r.command);

  EXPECT_TRUE(r.exited) << "jrgen died from a signal: status " << r.status << "\nstderr: " << r.err;
  EXPECT_EQ(r.status, 1) << "an error in the input or options exits 1 (docs/cli.md)";
  EXPECT_EQ(r.out, "") << "nothing on stdout on error";
  // Exactly one line on stderr.
  EXPECT_FALSE(r.err.empty()) << "no message on stderr";
  EXPECT_TRUE(ends_with(r.err, "\n")) << "stderr must end in a newline: [" << r.err << "]";
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1)
      << "stderr must be exactly one line:\n" << r.err;
  EXPECT_FALSE(contains(r.err, "internal error")) << r.err;
  for (const std::string& e : substitute(bad.expected, out, cwd))
    EXPECT_TRUE(contains(r.err, e)) << "stderr:   " << r.err << "expected: " << e;
  // Nothing created, modified or removed, temporaries included.
  const std::string out_diff = snapshot_diff(out_before, snapshot(out));
  EXPECT_EQ(out_diff, "") << "a failing run changed the output folder:\n" << out_diff;
  const std::string cwd_diff = snapshot_diff(cwd_before, snapshot(cwd));
  EXPECT_EQ(cwd_diff, "") << "a failing run changed the working folder:\n" << cwd_diff;
}

void expect_clean_failure(const BadRun& bad) {
  check_one_failure(bad, false);
  check_one_failure(bad, true);
}

const std::string kPendulum = (kCliDir / "pendulum.urdf").string();

// -- arguments ---------------------------------------------------------------

TEST(CliErrors, NoArguments) { expect_clean_failure({{}, {"MODEL.urdf"}, {}}); }

TEST(CliErrors, MissingModel) {
  expect_clean_failure({{"-o", "@OUT@/solver.cpp"}, {"MODEL.urdf"}, {}});
}

TEST(CliErrors, MissingOutput) {
  expect_clean_failure({{kPendulum}, {"missing -o OUT.cpp", "e.g. jrgen " + kPendulum + " -o pendulum.cpp"}, {}});
}

TEST(CliErrors, OutputOptionWithoutValue) {
  expect_clean_failure({{kPendulum, "-o"}, {"-o: missing value; write -o OUT.cpp"}, {}});
}

// "--cuts -o x.cpp": the value was forgotten; "-o" is not taken for a file.
TEST(CliErrors, OptionValueIsAnotherOption) {
  expect_clean_failure({{kPendulum, "--cuts", "-o", "@OUT@/solver.cpp"},
                        {"--cuts: missing value (the next argument, -o, is an option); write --cuts CUTS.xml"},
                        {}});
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--report", "--divide"},
                        {"--report: missing value", "write --report OPS.md"},
                        {}});
}

TEST(CliErrors, OptionWithEqualsSign) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--method=ldlt"},
                        {"unknown option '--method=ldlt'; write '--method ldlt'"},
                        {}});
}

TEST(CliErrors, MisspelledOptionNamesTheOptionMeant) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--namepsace", "x"},
                        {"unknown option '--namepsace'; did you mean --namespace?"},
                        {}});
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--strict-constraint"},
                        {"did you mean --strict-constraints?"},
                        {}});
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--frobnicate"},
                        {"unknown option '--frobnicate'; see jrgen --help"},
                        {}});
}

TEST(CliErrors, UnknownOption) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--frobnicate"}, {"--frobnicate"}, {}});
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "-x"}, {"'-x'"}, {}});
}

TEST(CliErrors, TwoModels) {
  expect_clean_failure({{kPendulum, kPendulum, "-o", "@OUT@/solver.cpp"},
                        {"more than one model", "further cut joints go in --cuts CUTS.xml"},
                        {}});
  // The output given without -o.
  expect_clean_failure({{kPendulum, "solver.cpp"}, {"more than one model", "write -o before the output solver.cpp"}, {}});
}

TEST(CliErrors, BadGravity) {
  for (const std::string g : {"1,2", "1,2,3,4", "1,2,x", "nan,0,0", "0,inf,0", "1,,3", "", "0 0 -9.81",
                              "1,2,3abc"}) {
    SCOPED_TRACE("--gravity '" + g + "'");
    expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--gravity", g}, {"--gravity", "e.g. --gravity 0,0,-9.81"}, {}});
  }
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--gravity"}, {"--gravity"}, {}});
}

TEST(CliErrors, BadMethod) {
  for (const std::string m : {"qr", "", "cholesky", "llt,ldlt"}) {
    SCOPED_TRACE("--method '" + m + "'");
    expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--method", m}, {"--method"}, {}});
  }
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--method"}, {"--method"}, {}});
}

// docs/interface.md section 1: a valid C++ identifier, not a keyword, not reserved
// ([lex.name]: "__" anywhere, a leading '_' at global scope), not empty.
TEST(CliErrors, BadNamespace) {
  for (const std::string ns : {"9lives", "a-b", "a::b", "a b", "", "__x", "a__b", "x__", "_X", "_x", "_", "int",
                               "class", "std", "posix", "jr", "caf\xc3\xa9"}) {
    SCOPED_TRACE("--namespace '" + ns + "'");
    expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--namespace", ns}, {"--namespace"}, {}});
  }
}

TEST(CliErrors, OutputMustEndInCpp) {
  // In particular -o solver.hpp must not overwrite the header.
  for (const std::string o : {"solver.hpp", "solver", "solver.cc", "solver.cpp.bak", "OPS.md"}) {
    SCOPED_TRACE("-o " + o);
    expect_clean_failure({{kPendulum, "-o", "@OUT@/" + o}, {"@OUT@/" + o, ".cpp"}, {}});
  }
}

// -- unwritable output (each fails even as root) -------------------------------

TEST(CliErrors, OutputFolderDoesNotExist) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/missing/solver.cpp"},
                        {"-o @OUT@/missing/solver.cpp: cannot write: the folder @OUT@/missing does not exist; create "
                         "it (mkdir -p @OUT@/missing)"},
                        {}});
}

TEST(CliErrors, OutputParentIsARegularFile) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/plain_file/solver.cpp"},
                        {"@OUT@/plain_file/solver.cpp", "@OUT@/plain_file is a file, not a folder"},
                        [](const fs::path& out, const fs::path&) { write_file(out / "plain_file", "x\n"); }});
}

TEST(CliErrors, OutputIsAFolder) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp"},
                        {"@OUT@/solver.cpp"},
                        [](const fs::path& out, const fs::path&) { fs::create_directories(out / "solver.cpp" / "sub"); }});
}

// OUT.cpp is writable but OUT.hpp is not: OUT.cpp must not be written either.
TEST(CliErrors, HeaderPathIsAFolder) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp"},
                        {"the header of -o @OUT@/solver.hpp: cannot write: it is a folder"},
                        [](const fs::path& out, const fs::path&) { fs::create_directories(out / "solver.hpp" / "sub"); }});
}

// OUT.cpp and OUT.hpp are writable but the report is not: neither may be written.
TEST(CliErrors, ReportPathIsAFolder) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--report", "@OUT@/OPS.md"},
                        {"@OUT@/OPS.md"},
                        [](const fs::path& out, const fs::path&) { fs::create_directories(out / "OPS.md" / "sub"); }});
}

TEST(CliErrors, ReportFolderDoesNotExist) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--report", "@OUT@/missing/OPS.md"},
                        {"--report @OUT@/missing/OPS.md: cannot write: the folder @OUT@/missing does not exist"},
                        {}});
}

// Not writable: by its permissions, or, for root, a read-only mount (EROFS).
TEST(CliErrors, ReadOnlyOutputFolder) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/ro/solver.cpp"},
                        {"@OUT@/ro/solver.cpp", "choose a folder you can write to"},
                        [](const fs::path& out, const fs::path&) {
                          fs::create_directories(out / "ro");
                          write_file(out / "ro" / "solver.cpp", "earlier\n");
                          fs::permissions(out / "ro", fs::perms::owner_read | fs::perms::owner_exec);
                        },
                        "ro"});
}

// -- no output onto an input or onto another output (docs/interface.md section 1) ----
// The inputs are copies in the working folder, so a regression damages only
// the copies; the snapshot of that folder then reports it.

// Copies the pendulum (as `urdf_name`) and, when asked, the HMMWV's cuts file
// into the working folder.
std::function<void(const fs::path&, const fs::path&)> copy_inputs(const std::string& urdf_name,
                                                                   bool hmmwv = false) {
  return [urdf_name, hmmwv](const fs::path&, const fs::path& cwd) {
    write_file(cwd / urdf_name, slurp(hmmwv ? kModelsDir / "hmmwv14.urdf" : fs::path(kPendulum)));
    if (hmmwv) write_file(cwd / "hmmwv14.cuts.xml", slurp(kModelsDir / "hmmwv14.cuts.xml"));
  };
}

TEST(CliErrors, ReportOntoTheModel) {
  expect_clean_failure({{"good.urdf", "-o", "@OUT@/solver.cpp", "--report", "good.urdf"},
                        {"--report good.urdf", "the model", "choose another path"},
                        copy_inputs("good.urdf")});
  // Another spelling of the same path.
  expect_clean_failure({{"good.urdf", "-o", "@OUT@/solver.cpp", "--report", "@CWD@/../cwd/./good.urdf"},
                        {"the model"},
                        copy_inputs("good.urdf")});
}

TEST(CliErrors, ReportOntoTheCutsFile) {
  expect_clean_failure({{"hmmwv.urdf", "--cuts", "hmmwv14.cuts.xml", "-o", "@OUT@/solver.cpp", "--report",
                         "hmmwv14.cuts.xml"},
                        {"--report hmmwv14.cuts.xml", "the --cuts file"},
                        copy_inputs("hmmwv.urdf", true)});
}

TEST(CliErrors, ReportOntoTheAssemblyStart) {
  expect_clean_failure({{"good.urdf", "-o", "@OUT@/solver.cpp", "--assemble-from", "q.txt", "--report", "q.txt"},
                        {"--report q.txt", "the --assemble-from file"},
                        [](const fs::path& out, const fs::path& cwd) {
                          copy_inputs("good.urdf")(out, cwd);
                          write_file(cwd / "q.txt", "0\n");
                        }});
}

TEST(CliErrors, ReportOntoTheGeneratedCode) {
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--report", "@OUT@/solver.cpp"},
                        {"--report @OUT@/solver.cpp", "also written by -o"},
                        {}});
  expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", "--report", "@OUT@/solver.hpp"},
                        {"--report @OUT@/solver.hpp", "also written by the header of -o"},
                        {}});
}

// An input named robot.hpp and -o robot.cpp: the header would replace it.
TEST(CliErrors, HeaderOntoTheModel) {
  expect_clean_failure({{"robot.hpp", "-o", "robot.cpp"}, {"the header of -o robot.hpp", "the model"},
                        copy_inputs("robot.hpp")});
}

TEST(CliErrors, OutputOntoTheModel) {
  expect_clean_failure({{"robot.cpp", "-o", "robot.cpp"}, {"-o robot.cpp", "the model"}, copy_inputs("robot.cpp")});
}

// Links: a symbolic link to the model, a hard link to it, a link to a folder
// holding it.
TEST(CliErrors, OutputsThroughLinksOntoTheModel) {
  auto with_links = [](const fs::path& out, const fs::path& cwd) {
    copy_inputs("good.urdf")(out, cwd);
    fs::create_symlink(cwd / "good.urdf", cwd / "soft.md");
    fs::create_hard_link(cwd / "good.urdf", cwd / "hard.md");
    fs::create_directory_symlink(cwd, cwd / "here");
    fs::create_symlink(cwd / "good.urdf", cwd / "soft.hpp");
  };
  expect_clean_failure({{"good.urdf", "-o", "@OUT@/solver.cpp", "--report", "soft.md"}, {"the model"}, with_links});
  expect_clean_failure({{"good.urdf", "-o", "@OUT@/solver.cpp", "--report", "hard.md"}, {"the model"}, with_links});
  expect_clean_failure({{"good.urdf", "-o", "@OUT@/solver.cpp", "--report", "here/good.urdf"}, {"the model"},
                        with_links});
  expect_clean_failure({{"good.urdf", "-o", "soft.cpp"}, {"the header of -o soft.hpp", "the model"}, with_links});
  // A report written through a link to the folder of OUT.cpp.
  expect_clean_failure({{"good.urdf", "-o", "solver.cpp", "--report", "here/solver.cpp"}, {"also written by -o"},
                        with_links});
}

// -- unreadable or unusable models -----------------------------------------------

TEST(CliErrors, ModelFileDoesNotExist) {
  const std::string missing = (kCliDir / "does_not_exist.urdf").string();
  expect_clean_failure({{missing, "-o", "@OUT@/solver.cpp"}, {missing, "cannot read"}, {}});
}

TEST(CliErrors, CutsFileDoesNotExist) {
  const std::string missing = (kCliDir / "does_not_exist.cuts.xml").string();
  expect_clean_failure({{kPendulum, "--cuts", missing, "-o", "@OUT@/solver.cpp"}, {missing, "cannot read"}, {}});
}

TEST(CliErrors, ModelIsAFolder) {
  expect_clean_failure({{kCliDir.string(), "-o", "@OUT@/solver.cpp"}, {kCliDir.string()}, {}});
}

TEST(CliErrors, NoMovingJoints) {
  const std::string welded = (kCliDir / "no_moving_joints.urdf").string();
  expect_clean_failure({{welded, "-o", "@OUT@/solver.cpp"}, {welded, "'welded'", "no moving joints"}, {}});
  // A single link, no joint at all.
  expect_clean_failure({{"brick.urdf", "-o", "@OUT@/solver.cpp"},
                        {"brick.urdf", "'brick'", "no moving joints"},
                        [](const fs::path&, const fs::path& cwd) {
                          write_file(cwd / "brick.urdf", "<robot name=\"brick\"><link name=\"b\"/></robot>\n");
                        }});
}

int line_of(const fs::path& file, const std::string& needle) {
  const std::vector<std::string> lines = split_lines(slurp(file));
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (contains(lines[i], needle)) return static_cast<int>(i) + 1;
  return 0;
}

// romeo's LHand joint carries only massless links: M is singular whatever q.
TEST(CliErrors, RomeoLHandMovesNoMass) {
  const fs::path romeo = kExternalModelsDir / "romeo.urdf";
  ASSERT_TRUE(fs::exists(romeo)) << romeo;
  const int line = line_of(romeo, "<joint name=\"LHand\"");
  ASSERT_GT(line, 0);
  expect_clean_failure({{romeo.string(), "-o", "@OUT@/solver.cpp", "--report", "@OUT@/OPS.md"},
                        {romeo.string() + ":" + std::to_string(line) + ":", "<joint> 'LHand'", "mass",
                         "--bound-mass", "--bound-inertia"},
                        {}});
}

TEST(CliErrors, BadMassBounds) {
  for (const std::string option : {"--bound-mass", "--bound-inertia"}) {
    for (const std::string value : {"0", "-1", "nan", "inf", "1e-3kg", ""}) {
      SCOPED_TRACE(option + " '" + value + "'");
      expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", option, value}, {option, "positive"}, {}});
    }
    expect_clean_failure({{kPendulum, "-o", "@OUT@/solver.cpp", option}, {option, "missing value"}, {}});
  }
}

// With bounds (as MuJoCo's boundmass, boundinertia) romeo loads: one note per
// body raised, each naming its joint and the option that raised it.
TEST(CliOutput, RomeoLoadsWithMassBounds) {
  const fs::path romeo = kExternalModelsDir / "romeo.urdf";
  ScratchDir scratch("jrgen_romeo");
  const RunResult r = run_jrgen({romeo.string(), "-o", (scratch / "romeo.cpp").string(), "--bound-mass", "1e-3",
                                 "--bound-inertia", "1e-6"},
                                scratch.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<std::string> lines = split_lines(r.err);
  std::vector<std::string> joints;
  for (const std::string& line : lines) {
    if (!contains(line, "--bound-")) continue;
    EXPECT_TRUE(contains(line, "jrgen: note: ")) << line;
    const std::size_t at = line.find("<joint> '");
    ASSERT_NE(at, std::string::npos) << line;
    joints.push_back(line.substr(at + 9, line.find('\'', at + 9) - at - 9));
  }
  EXPECT_NE(std::find(joints.begin(), joints.end(), "LHand"), joints.end());
  std::vector<std::string> unique = joints;
  std::sort(unique.begin(), unique.end());
  EXPECT_EQ(std::unique(unique.begin(), unique.end()), unique.end()) << "one note per body";
  EXPECT_TRUE(fs::exists(scratch / "romeo.hpp"));
}

// Elements and attributes that URDF parsers ignore but are most likely typos
// (<axiss>: the joint would turn about x): one note each, and the run succeeds.
TEST(CliOutput, MisspelledElementsGiveNotes) {
  ScratchDir scratch("jrgen_typo");
  write_file(scratch / "typo.urdf", R"(<robot name="typo">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="j" type="continuous"><parent link="base"/><child link="arm"/><axiss xyz="0 0 1"/></joint>
</robot>)");
  const RunResult r = run_jrgen({"typo.urdf", "-o", "solver.cpp"}, scratch.path());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err,
            "jrgen: note: typo.urdf:4: <joint> 'j': <axiss> is not a URDF element inside <joint> and is ignored; "
            "did you mean <axis>?\n");
}

// Finite numbers near DBL_MAX whose derived constants stay finite generate
// code without inf or nan in it (those that overflow are tests/errors/overflow_*).
TEST(CliOutput, HugeButRepresentableNumbersGiveFiniteConstants) {
  ScratchDir scratch("jrgen_huge");
  write_file(scratch / "huge.urdf", R"(<robot name="huge">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
    <inertia ixx="1e308" ixy="0" ixz="0" iyy="1e308" iyz="0" izz="1e308"/></inertial></link>
  <joint name="shoulder" type="continuous"><parent link="base"/><child link="arm"/>
    <origin xyz="1e308 0 -1e308"/><axis xyz="0 1 0"/></joint>
</robot>)");
  const RunResult r = run_jrgen({"huge.urdf", "-o", "solver.cpp"}, scratch.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const std::regex non_finite(R"(\b(inf|nan|INF|NAN)\b)");
  EXPECT_FALSE(std::regex_search(slurp(scratch / "solver.cpp"), non_finite));
}

// --threads N on a tree too small for Corollary 3's partition (every dof of a
// short chain fits in the separator: no subtree left to run in parallel) was
// an internal error (std::bad_alloc from an empty subtree table).  It now
// generates the serial solver, the same as --threads 1, with a note.
TEST(CliOutput, ThreadsOnAChainWithoutSubtreesGivesTheSerialSolver) {
  ScratchDir scratch("jrgen_threads");
  const std::string arm7 = (kModelsDir / "arm7.urdf").string();
  const RunResult parallel = run_jrgen({arm7, "--threads", "2", "-o", "par.cpp"}, scratch.path());
  ASSERT_EQ(parallel.status, 0) << parallel.command << "\n" << parallel.err;
  EXPECT_TRUE(contains(parallel.err, "jrgen: note: --threads 2:")) << parallel.err;
  const RunResult serial = run_jrgen({arm7, "--threads", "1", "-o", "ser.cpp"}, scratch.path());
  ASSERT_EQ(serial.status, 0) << serial.command << "\n" << serial.err;
  std::string par_code = slurp(scratch / "par.cpp"), ser_code = slurp(scratch / "ser.cpp");
  EXPECT_FALSE(contains(par_code, "omp parallel"));
  EXPECT_EQ(par_code.replace(par_code.find("par.hpp"), 7, "ser.hpp"), ser_code);
}

// -- every case in tests/errors/ -----------------------------------------------

struct FolderCase {
  std::string file;  // name in tests/errors
  bool cuts;         // .cuts.xml (else .urdf)
  std::string stem;
};

std::vector<FolderCase> folder_cases() {
  std::vector<FolderCase> cases;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(kErrorsDir, ec)) {
    const std::string name = entry.path().filename().string();
    if (ends_with(name, ".urdf")) cases.push_back({name, false, name.substr(0, name.size() - 5)});
    else if (ends_with(name, ".cuts.xml")) cases.push_back({name, true, name.substr(0, name.size() - 9)});
  }
  std::sort(cases.begin(), cases.end(), [](const FolderCase& a, const FolderCase& b) { return a.file < b.file; });
  return cases;
}

void PrintTo(const FolderCase& c, std::ostream* os) { *os << c.file; }

class CliErrorFolder : public ::testing::TestWithParam<FolderCase> {};

TEST_P(CliErrorFolder, FailsCleanlyWithTheExpectedMessage) {
  const FolderCase& c = GetParam();
  const fs::path file = kErrorsDir / c.file;
  const fs::path expected_file = kErrorsDir / (c.stem + ".expected");
  ASSERT_TRUE(fs::exists(expected_file)) << expected_file;
  const std::string expected = trim_newlines(slurp(expected_file));
  ASSERT_FALSE(expected.empty());
  // The .expected text starts with the case's file name; jrgen names the
  // file as it was given, so the message holds the folder, then that text.
  ASSERT_EQ(expected.rfind(c.file, 0), 0u) << expected;
  const std::string full = kErrorsDir.string() + "/" + expected;
  if (!c.cuts) {
    expect_clean_failure({{file.string(), "-o", "@OUT@/solver.cpp", "--report", "@OUT@/OPS.md"}, {full}, {}});
  } else {
    // The base robot of the .cuts.xml cases (the one urdf_reader_test.cpp
    // defines inline), copied into the working folder and named relative to
    // it: the cases' messages cite it as "cuts_base.urdf:LINE".
    expect_clean_failure({{"cuts_base.urdf", "--cuts", file.string(), "-o", "@OUT@/solver.cpp", "--report",
                           "@OUT@/OPS.md"},
                          {full},
                          [](const fs::path&, const fs::path& cwd) {
                            fs::copy_file(kCliDir / "cuts_base.urdf", cwd / "cuts_base.urdf");
                          }});
  }
}

std::string folder_case_name(const ::testing::TestParamInfo<FolderCase>& info) {
  std::string name = info.param.stem + (info.param.cuts ? "_cuts" : "_urdf");
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(TestsErrors, CliErrorFolder, ::testing::ValuesIn(folder_cases()), folder_case_name);

// The folder sweep must hold the cases docs/interface.md section 1 singles out.
TEST(CliErrors, FolderHoldsTheRequiredCases) {
  const std::vector<FolderCase> cases = folder_cases();
  EXPECT_GE(cases.size(), 40u);
  for (const std::string required :
       {"malformed_xml.urdf", "unknown_link.urdf", "bad_inertia.urdf", "nan_value.urdf", "nan_inertia.urdf",
        "unknown_joint_type.urdf", "cuts_malformed.cuts.xml", "bad_cut_link.cuts.xml"})
    EXPECT_TRUE(std::any_of(cases.begin(), cases.end(), [&](const FolderCase& c) { return c.file == required; }))
        << required;
}

// The base robot of the .cuts.xml cases is valid on its own.
TEST(CliErrors, CutsBaseRobotIsValid) {
  ScratchDir scratch("jrgen_cli");
  const RunResult r = run_jrgen({(kCliDir / "cuts_base.urdf").string(), "-o", (scratch / "solver.cpp").string()},
                                scratch.path());
  EXPECT_EQ(r.status, 0) << r.command << "\n" << r.err;
  EXPECT_TRUE(fs::exists(scratch / "solver.cpp"));
}

// ===========================================================================
// --help, --version
// ===========================================================================

void expect_info(const std::vector<std::string>& args, const std::function<void(const std::string&)>& check) {
  ScratchDir scratch("jrgen_cli");
  const RunResult r = run_jrgen(args, scratch.path());
  SCOPED_TRACE(r.command);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_FALSE(r.out.empty());
  EXPECT_TRUE(ends_with(r.out, "\n"));
  EXPECT_EQ(snapshot(scratch.path()), Snapshot{}) << "--help/--version must not write files";
  check(r.out);
}

TEST(CliInfo, Help) {
  const auto check = [](const std::string& out) {
    EXPECT_TRUE(contains(out, "usage: jrgen")) << out;
    for (const char* option : {"MODEL.urdf", "--cuts", "-o", "--namespace", "--gravity", "--method", "llt",
                               "ldlt", "--report", "--strict-constraints", "--help", "--version"})
      EXPECT_TRUE(contains(out, option)) << "--help does not mention " << option << ":\n" << out;
  };
  expect_info({"--help"}, check);
  expect_info({"-h"}, check);
  // --help wins over anything else on the line, even bad arguments.
  expect_info({kPendulum, "--help", "-o", "x.hpp"}, check);
  expect_info({"--frobnicate", "--help"}, check);
}

TEST(CliInfo, Version) {
  expect_info({"--version"}, [](const std::string& out) {
    EXPECT_TRUE(std::regex_match(out, std::regex("jrgen [0-9]+\\.[0-9]+\\.[0-9]+[^\n]*\n"))) << out;
  });
  // The version in the banner of the generated code is the same.
  ScratchDir scratch("jrgen_cli");
  const RunResult v = run_jrgen({"--version"}, scratch.path());
  const RunResult r = run_jrgen({kPendulum, "-o", (scratch / "solver.cpp").string()}, scratch.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string version = trim_newlines(v.out).substr(6);
  EXPECT_TRUE(contains(slurp(scratch / "solver.cpp"), version)) << version;
}

// ===========================================================================
// Successful runs
// ===========================================================================

TEST(CliOutput, WritesOutCppAndOutHppOnly) {
  ScratchDir scratch("jrgen_cli");
  fs::create_directories(scratch / "out");
  const RunResult r = run_jrgen({kPendulum, "-o", "out/pend.cpp"}, scratch.path());
  SCOPED_TRACE(r.command);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "") << "a tree model generates silently";
  const Snapshot s = snapshot(scratch.path());
  std::vector<std::string> names;
  for (const auto& [name, text] : s) names.push_back(name);
  EXPECT_EQ(names, (std::vector<std::string>{"out", "out/pend.cpp", "out/pend.hpp"}));
  EXPECT_TRUE(contains(s.at("out/pend.cpp"), "#include \"pend.hpp\""));
  // Default namespace: the robot name.
  EXPECT_TRUE(contains(s.at("out/pend.hpp"), "namespace pendulum {"));
  EXPECT_TRUE(contains(s.at("out/pend.hpp"), "inline constexpr int nv = 1;"));
}

TEST(CliOutput, ReplacesEarlierOutputsAndLeavesNoTemporaries) {
  ScratchDir scratch("jrgen_cli");
  write_file(scratch / "solver.cpp", "earlier\n");
  write_file(scratch / "solver.hpp", "earlier\n");
  write_file(scratch / "OPS.md", "earlier\n");
  const RunResult r = run_jrgen({kPendulum, "-o", "solver.cpp", "--report", "OPS.md", "--namespace", "pend"},
                                scratch.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const Snapshot s = snapshot(scratch.path());
  EXPECT_EQ(s.size(), 3u) << snapshot_diff({}, s);
  EXPECT_NE(s.at("solver.cpp"), "earlier\n");
  EXPECT_NE(s.at("OPS.md"), "earlier\n");
  EXPECT_TRUE(contains(s.at("solver.hpp"), "namespace pend {"));
}

// A robot name that is not a usable namespace is fixed up deterministically
// (emit::sanitize_identifier): never reserved, never a keyword.
TEST(CliOutput, DerivedNamespaceIsAValidIdentifier) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"my robot", "my_robot"},     {"__Hidden", "Hidden"},      {"a__b", "a_b"},       {"_Xyz", "Xyz"},
      {"9lives", "robot_9lives"},   {"class", "class_"},         {"std", "std_"},       {"---", "robot_"},
      {"x__", "x_"},                {"caf\xc3\xa9", "caf_"}};
  for (const auto& [name, expected] : cases) {
    SCOPED_TRACE("robot name '" + name + "'");
    ScratchDir scratch("jrgen_ns");
    std::string urdf = slurp(kPendulum);
    const std::size_t at = urdf.find("name=\"", urdf.find("<robot"));
    ASSERT_NE(at, std::string::npos);
    const std::size_t end = urdf.find('"', at + 6);
    urdf.replace(at + 6, end - at - 6, name);
    write_file(scratch / "robot.urdf", urdf);
    const RunResult r = run_jrgen({"robot.urdf", "-o", "solver.cpp"}, scratch.path());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(slurp(scratch / "solver.hpp"), "namespace " + expected + " {")) << expected;
  }
}

TEST(CliOutput, ReportOnlyWhenAsked) {
  ScratchDir scratch("jrgen_cli");
  const RunResult r = run_jrgen({kPendulum, "-o", "solver.cpp"}, scratch.path());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(snapshot(scratch.path()).size(), 2u);
}

TEST(CliOutput, ZeroGravityRemovesGravityCode) {
  ScratchDir scratch("jrgen_cli");
  const std::string arm7 = (kModelsDir / "arm7.urdf").string();
  fs::create_directories(scratch / "g");
  fs::create_directories(scratch / "z");
  ASSERT_EQ(run_jrgen({arm7, "-o", "g/solver.cpp"}, scratch.path()).status, 0);
  ASSERT_EQ(run_jrgen({arm7, "-o", "z/solver.cpp", "--gravity", "0,0,0"}, scratch.path()).status, 0);
  const std::string with = slurp(scratch / "g" / "solver.cpp");
  const std::string without = slurp(scratch / "z" / "solver.cpp");
  EXPECT_TRUE(contains(with, "9.81"));
  EXPECT_FALSE(contains(without, "9.81"));
  EXPECT_NE(with, without);
}

// Large solvers (generator/emit/kernel.hpp: kMinOpsSeparateSteps) pass values
// between the blocks of Steps 1, 3.1-3.3 and 3.5 through memory: a
// jr::compiler_fence() once at least kFenceProducts = 64 products (" * ") have
// been written since the function's start or the last fence.  Steps 2 and 4,
// and every step of a small solver, have none.
TEST(CliOutput, FencesOnlyInTheLongStepsOfLargeSolvers) {
  ScratchDir scratch("jrgen_cli");
  fs::create_directories(scratch / "a");
  fs::create_directories(scratch / "h");
  ASSERT_EQ(run_jrgen({(kModelsDir / "arm7.urdf").string(), "-o", "a/solver.cpp"}, scratch.path()).status, 0);
  ASSERT_EQ(run_jrgen({(kModelsDir / "hmmwv14.urdf").string(), "--cuts", (kModelsDir / "hmmwv14.cuts.xml").string(),
                       "-o", "h/solver.cpp"},
                      scratch.path())
                .status,
            0);
  EXPECT_FALSE(contains(slurp(scratch / "a" / "solver.cpp"), "compiler_fence"));

  const std::string large = slurp(scratch / "h" / "solver.cpp");
  const std::vector<std::string> fenced = {"step1_factor(",  "step1_factor_dense(", "step31_solve_T(",
                                           "step32_rhs(",    "step33_TtT(",         "step35_update("};
  std::map<std::string, int> fences;  // function -> fences in it
  std::string function;               // the step being read, "" outside
  std::size_t products = 0;           // " * " since its start or the last fence
  for (std::string line : split_lines(large)) {
    if (line.rfind("JRGEN_DISPATCH ", 0) == 0) line.erase(0, std::string("JRGEN_DISPATCH ").size());
    if (line.rfind("JRGEN_STEP ", 0) == 0) {
      function = line.substr(line.find(' ', std::string("JRGEN_STEP ").size()) + 1);
      function = function.substr(0, function.find('(') + 1);
      products = 0;
      continue;
    }
    if (line == "}") function.clear();
    if (line.find("jr::compiler_fence();") != std::string::npos) {
      EXPECT_NE(std::find(fenced.begin(), fenced.end(), function), fenced.end()) << "fence in '" << function << "'";
      EXPECT_GE(products, 64u) << "in " << function;
      ++fences[function];
      products = 0;
      continue;
    }
    for (std::size_t at = line.find(" * "); at != std::string::npos; at = line.find(" * ", at + 3)) ++products;
  }
  for (const char* f : {"step1_factor(", "step1_factor_dense(", "step31_solve_T(", "step32_rhs(", "step35_update("})
    EXPECT_GT(fences[f], 0) << f;
  EXPECT_EQ(fences["step2_forward("], 0);
  EXPECT_EQ(fences["step4_backward("], 0);
}

// ===========================================================================
// Determinism
// ===========================================================================

struct DeterminismCase {
  std::string model;  // file in models/
  std::string cuts;   // file in models/, or ""
  std::vector<std::string> options;
  std::string name;
};

std::vector<DeterminismCase> determinism_cases() {
  std::vector<std::string> models;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(kModelsDir, ec))
    if (entry.path().extension() == ".urdf") models.push_back(entry.path().filename().string());
  std::sort(models.begin(), models.end());
  std::vector<DeterminismCase> cases;
  for (const std::string& m : models) {
    const std::string stem = m.substr(0, m.size() - 5);
    cases.push_back({m, "", {}, stem});
    cases.push_back({m, "", {"--method", "ldlt"}, stem + "_ldlt"});
    cases.push_back({m, "", {"--gravity", "0,0,0"}, stem + "_nogravity"});
    if (fs::exists(kModelsDir / (stem + ".cuts.xml"))) {
      cases.push_back({m, stem + ".cuts.xml", {}, stem + "_cuts"});
      cases.push_back({m, stem + ".cuts.xml", {"--method", "ldlt"}, stem + "_cuts_ldlt"});
    }
  }
  return cases;
}

void PrintTo(const DeterminismCase& c, std::ostream* os) { *os << c.name; }

class CliDeterminism : public ::testing::TestWithParam<DeterminismCase> {};

// Strings that must not leak into generated files.
std::vector<std::string> forbidden_strings(const std::vector<fs::path>& dirs) {
  std::vector<std::string> f;
  auto add_path = [&](const fs::path& p) {
    f.push_back(p.string());
    std::error_code ec;
    const fs::path canon = fs::weakly_canonical(p, ec);
    if (!ec) f.push_back(canon.string());
  };
  add_path(kSourceDir);
  add_path(kModelsDir);
  add_path(JRGEN_BINARY_DIR);
  for (const fs::path& d : dirs) add_path(d);
  f.push_back(fs::path(::testing::TempDir()).string());
  if (const char* home = std::getenv("HOME"); home && std::string(home).size() > 1) f.push_back(home);
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) == 0 && std::string(host).size() >= 6) f.push_back(host);
  if (const char* user = std::getenv("USER"); user && std::string(user).size() >= 6) f.push_back(user);
  // Today's date in the usual spellings (ISO, __DATE__, ctime).
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::localtime_r(&now, &tm);
  for (const char* fmt : {"%Y-%m-%d", "%b %e %Y", "%b %d %Y", "%d %b %Y", "%Y/%m/%d", "%d.%m.%Y"}) {
    char buf[64];
    if (std::strftime(buf, sizeof buf, fmt, &tm)) f.push_back(buf);
  }
  return f;
}

void expect_no_leaks(const std::string& name, const std::string& text, const std::vector<std::string>& forbidden) {
  for (const std::string& s : forbidden)
    EXPECT_FALSE(contains(text, s)) << name << " contains '" << s << "'";
  static const std::regex iso_date("(19|20)[0-9][0-9]-[01][0-9]-[0-3][0-9]");
  static const std::regex clock_time("[0-2][0-9]:[0-5][0-9]:[0-5][0-9]");
  static const std::regex abs_path("(^|[\\s\"'(])/(home|tmp|work|root|usr|opt|var|build)/");
  std::smatch m;
  EXPECT_FALSE(std::regex_search(text, m, iso_date)) << name << " contains a date: " << m.str();
  EXPECT_FALSE(std::regex_search(text, m, clock_time)) << name << " contains a time: " << m.str();
  EXPECT_FALSE(std::regex_search(text, m, abs_path)) << name << " contains an absolute path: " << m.str();
}

// Run A from an empty folder with absolute input paths and a relative -o;
// run B from another folder with relative input paths and absolute outputs.
TEST_P(CliDeterminism, SameInputsSameBytes) {
  const DeterminismCase& c = GetParam();
  ScratchDir a("jrgen_det_a");
  ScratchDir b("jrgen_det_b");
  fs::create_directories(a / "out");
  fs::create_directories(b / "deeper" / "cwd");
  const fs::path b_cwd = b / "deeper" / "cwd";

  std::vector<std::string> args_a = {(kModelsDir / c.model).string()};
  std::vector<std::string> args_b = {fs::relative(kModelsDir / c.model, b_cwd).string()};
  if (!c.cuts.empty()) {
    args_a.insert(args_a.end(), {"--cuts", (kModelsDir / c.cuts).string()});
    args_b.insert(args_b.end(), {"--cuts", fs::relative(kModelsDir / c.cuts, b_cwd).string()});
  }
  args_a.insert(args_a.end(), {"-o", "out/solver.cpp", "--report", "out/OPS.md"});
  args_b.insert(args_b.end(), {"--report", (b / "OPS.md").string(), "-o", (b / "solver.cpp").string()});
  args_a.insert(args_a.end(), c.options.begin(), c.options.end());
  args_b.insert(args_b.end(), c.options.begin(), c.options.end());

  const RunResult ra = run_jrgen(args_a, a.path());
  ASSERT_EQ(ra.status, 0) << ra.command << "\n" << ra.err;
  const RunResult rb = run_jrgen(args_b, b_cwd);
  ASSERT_EQ(rb.status, 0) << rb.command << "\n" << rb.err;
  EXPECT_EQ(ra.out, rb.out);
  // Notes on stderr (dropped constraint rows) name the input files as given,
  // which differs between the two runs by design; the rest must not.
  const auto normalize = [&](std::string text, const std::vector<std::string>& args) {
    std::vector<std::string> paths = {args[0]};
    if (!c.cuts.empty()) paths.push_back(args[2]);
    for (const std::string& p : paths)
      for (std::size_t k = text.find(p); k != std::string::npos; k = text.find(p, k + 5)) text.replace(k, p.size(), "INPUT");
    return text;
  };
  EXPECT_EQ(normalize(ra.err, args_a), normalize(rb.err, args_b));

  const std::vector<std::string> forbidden = forbidden_strings({a.path(), b.path(), b_cwd});
  for (const char* name : {"solver.cpp", "solver.hpp", "OPS.md"}) {
    SCOPED_TRACE(name);
    const std::string text_a = slurp(a / "out" / name);
    const std::string text_b = slurp(b / name);
    EXPECT_FALSE(text_a.empty());
    const std::string diff = first_difference(text_a, text_b);
    EXPECT_EQ(diff, "") << "two runs on the same inputs differ";
    expect_no_leaks(name, text_a, forbidden);
  }
  EXPECT_FALSE(fs::exists(b_cwd / "out"));
  EXPECT_EQ(snapshot(b_cwd), Snapshot{}) << "nothing is written to the working folder";
}

std::string determinism_case_name(const ::testing::TestParamInfo<DeterminismCase>& info) {
  std::string name = info.param.name;
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Models, CliDeterminism, ::testing::ValuesIn(determinism_cases()), determinism_case_name);

TEST(CliDeterminismSetup, ProjectModelsAreAllListed) {
  std::vector<std::string> names;
  for (const DeterminismCase& c : determinism_cases()) names.push_back(c.name);
  for (const char* required : {"arm7", "arm7_ldlt", "arm7_nogravity", "legged30", "hmmwv14", "hmmwv14_cuts",
                               "stewart", "stewart_cuts"})
    EXPECT_NE(std::find(names.begin(), names.end(), required), names.end()) << required;
}

// ===========================================================================
// --report
// ===========================================================================

constexpr std::array<const char*, 8> kSteps = {"1", "2", "3.1", "3.2", "3.3", "3.4", "3.5", "4"};
constexpr std::array<const char*, 4> kRows = {"A", "M", "D", "SQ"};

struct OpTable {
  // counts[row][column]: rows A, M, D, SQ; columns the 8 steps then Total.
  std::array<std::array<long long, 9>, 4> counts{};
  long long at(const char* row, const char* step) const {
    const auto r = std::find_if(kRows.begin(), kRows.end(), [&](const char* x) { return std::string(x) == row; });
    const auto c = std::find_if(kSteps.begin(), kSteps.end(), [&](const char* x) { return std::string(x) == step; });
    return counts.at(r - kRows.begin()).at(c - kSteps.begin());
  }
};

std::vector<std::string> table_cells(const std::string& line) {
  std::vector<std::string> cells;
  if (line.size() < 2 || line.front() != '|' || line.back() != '|') return cells;
  std::size_t pos = 1;
  while (pos < line.size()) {
    const std::size_t end = line.find('|', pos);
    std::string cell = line.substr(pos, end - pos);
    const auto b = cell.find_first_not_of(' ');
    const auto e = cell.find_last_not_of(' ');
    cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    pos = end + 1;
  }
  return cells;
}

// Parses the report's table and checks its shape; fails the test when the
// shape is wrong.
void parse_report(const std::string& report, OpTable* table) {
  const std::vector<std::string> lines = split_lines(report);
  // This model's table comes first; the paper's reference tables follow
  // under "## Reference" and must carry its Alg-S totals.
  std::vector<std::string> table_lines;
  bool reference = false;
  for (const std::string& l : lines) {
    if (l.rfind("## Reference", 0) == 0) reference = true;
    if (!reference && !l.empty() && l.front() == '|') table_lines.push_back(l);
  }
  EXPECT_TRUE(reference) << "no reference section with the paper's tables\n" << report;
  EXPECT_NE(report.find("| A | 975 | 165 | 708 | 172 | 834 | 680 | 145 | 192 | 3871 |"), std::string::npos);
  ASSERT_EQ(table_lines.size(), 6u) << "one table: header, separator, rows A, M, D, SQ\n" << report;
  const std::vector<std::string> header = table_cells(table_lines[0]);
  const std::vector<std::string> expected_header = {"", "1", "2", "3.1", "3.2", "3.3", "3.4", "3.5", "4", "Total"};
  ASSERT_EQ(header, expected_header) << table_lines[0];
  const std::vector<std::string> sep = table_cells(table_lines[1]);
  ASSERT_EQ(sep.size(), 10u) << table_lines[1];
  for (const std::string& s : sep) EXPECT_TRUE(std::regex_match(s, std::regex(":?-{3,}:?"))) << table_lines[1];
  // The lines of the table are consecutive.
  const auto first = std::find(lines.begin(), lines.end(), table_lines[0]);
  for (std::size_t k = 0; k < 6; ++k) ASSERT_EQ(*(first + k), table_lines[k]);
  for (std::size_t r = 0; r < kRows.size(); ++r) {
    const std::vector<std::string> cells = table_cells(table_lines[2 + r]);
    ASSERT_EQ(cells.size(), 10u) << table_lines[2 + r];
    ASSERT_EQ(cells[0], kRows[r]) << table_lines[2 + r];
    long long sum = 0;
    for (std::size_t c = 1; c < 10; ++c) {
      ASSERT_TRUE(std::regex_match(cells[c], std::regex("[0-9]+"))) << "not a count: '" << cells[c] << "' in "
                                                                     << table_lines[2 + r];
      table->counts[r][c - 1] = std::stoll(cells[c]);
      if (c < 9) sum += table->counts[r][c - 1];
    }
    EXPECT_EQ(table->counts[r][8], sum) << "Total of row " << kRows[r] << " is not the sum of the steps";
  }
}

int header_constant(const std::string& hpp, const std::string& name) {
  std::smatch m;
  const std::regex re("inline constexpr int " + name + " = ([0-9]+);");
  if (!std::regex_search(hpp, m, re)) return -1;
  return std::stoi(m[1]);
}

// An independent recount of the arithmetic of one emitted step.  The step's
// code is the function after each "// ---- Step K:" (or "// ---- Step K (a):",
// for a step emitted in parts) banner; in its body, comments and the pivot guard line (`if (!(d > kPivotTolerance *
// L[..])) return ...;`, a test, not part of the factorization) are skipped,
// and every binary + - * / between blanks, every compound += -= *= /= and
// every std::sqrt( is one operation.  (Unary minus and numeric exponents
// have no blank after the sign, so they are not counted.)
struct Recount {
  long long add = 0, mul = 0, div = 0, sqrt = 0;
  bool found = false;
};

// The runtime's dense Schur loops (jrgen/constraint_solve.hpp) that a
// closed-loop solver calls for the dense part of Steps 3.3 and 3.4: their
// arithmetic, counted by hand from the loops, from the call's size arguments.
//   schur_dense_gram(A, B, k, m, W): each of the m(m+1)/2 entries is a k-term
//     dot product: k M, k - 1 A.
//   schur_dense_factor(W, Winv, m, ldlt, ...): right-looking; pivot j is
//     one reciprocal (D), then each later column s takes f = w[s, j] / d_j
//     (one M) and updates its m - s rows (m - s M and A).  L L^T then scales
//     each column: a square root, 1 / sqrt(d) = sqrt(d) * (1 / d) (one M)
//     and m - 1 - j products.
//   schur_dense_solve(W, Winv, m, order, ldlt, ...): forward and backward each
//     m (m - 1) / 2 products and subtractions, and the scalings by Winv: m in
//     each direction for L L^T, m in the backward one for L D L^T.
//   schur_dense_factor_forward(W, Winv, m, order, ldlt, ...): the factor
//     above, and the forward substitution in the same passes: for each pivot
//     with rows below, g = u / d (one M), then a product and a subtraction
//     per row below (m - 1 - j M and A); L L^T then scales each y (one M).
//   schur_dense_backward(W, Winv, m, order, ldlt, ...): the backward half of
//     schur_dense_solve: m (m - 1) / 2 products and subtractions, m scalings.
//   The square layout's variants take the sizes as template arguments
//   instead (schur_square_gram_fixed<k, m>(A, B, W), and
//   schur_square_X_fixed<m>(W, Winv, ...) for the others): the same
//   arithmetic on the entries that are read, the same counts.  (Their loops
//   also run over entries no result reads, above the diagonal and in the
//   padding row: not counted.)
bool count_dense_kernel(const std::string& raw, Recount* rc) {
  // jr::schur_square_gram_fixed<k, m>(A, B, W) -> jr::schur_dense_gram(A, B, k, m, W)
  static const std::regex kGramFixed(R"(jr::schur_square_gram_fixed<(\d+), (\d+)>\(([^,]+),([^,]+),)");
  // jr::schur_square_X_fixed<m>(W, Winv, ...) -> jr::schur_dense_X(W, Winv, m, ...)
  static const std::regex kFixed(R"(jr::schur_square_(\w+)_fixed<(\d+)>\(([^,]+),([^,]+),)");
  const std::string line = std::regex_replace(std::regex_replace(raw, kGramFixed, "jr::schur_dense_gram($3,$4, $1, $2,"),
                                              kFixed, "jr::schur_dense_$1($3,$4, $2,");
  auto args = [&](const std::string& name) {
    std::vector<std::string> out;
    const std::size_t at = line.find(name + "(");
    if (at == std::string::npos) return out;
    std::size_t p = at + name.size() + 1;
    std::string cur;
    for (int depth = 0; p < line.size(); ++p) {
      const char ch = line[p];
      if (ch == '(') ++depth;
      if (ch == ')' && depth-- == 0) break;
      if (ch == ',' && depth == 0) {
        out.push_back(cur);
        cur.clear();
      } else if (ch != ' ') {
        cur += ch;
      }
    }
    out.push_back(cur);
    return out;
  };
  if (const auto a = args("jr::schur_dense_gram"); !a.empty()) {
    const long long k = std::stoll(a.at(2)), m = std::stoll(a.at(3)), entries = m * (m + 1) / 2;
    rc->mul += entries * k;
    rc->add += entries * (k - 1);
    return true;
  }
  // The factorization, with or without the forward substitution.
  const bool forward = !args("jr::schur_dense_factor_forward").empty();
  if (const auto a = forward ? args("jr::schur_dense_factor_forward") : args("jr::schur_dense_factor"); !a.empty()) {
    const long long m = std::stoll(a.at(2));
    const bool ldlt = a.at(forward ? 4 : 3) == "true";
    if (forward) {
      for (long long j = 0; j < m; ++j) {
        if (j + 1 < m) rc->mul += 1;
        rc->mul += m - 1 - j;
        rc->add += m - 1 - j;
        if (!ldlt) rc->mul += 1;
      }
    }
    for (long long j = 0; j < m; ++j) {
      rc->div += 1;
      for (long long s = j + 1; s < m; ++s) {
        rc->mul += 1 + (m - s);
        rc->add += m - s;
      }
      if (!ldlt) {
        rc->sqrt += 1;
        rc->mul += 1 + (m - 1 - j);
      }
    }
    return true;
  }
  if (const auto a = args("jr::schur_dense_backward"); !a.empty()) {
    const long long m = std::stoll(a.at(2));
    rc->mul += m * (m - 1) / 2 + m;
    rc->add += m * (m - 1) / 2;
    return true;
  }
  if (const auto a = args("jr::schur_dense_solve"); !a.empty()) {
    const long long m = std::stoll(a.at(2));
    const bool ldlt = a.at(4) == "true";
    rc->mul += m * (m - 1) + (ldlt ? m : 2 * m);
    rc->add += m * (m - 1);
    return true;
  }
  return false;
}

Recount recount_step(const std::string& cpp, const std::string& step) {
  Recount rc;
  const std::vector<std::string> lines = split_lines(cpp);
  // A step may be emitted as several parts: "// ---- Step 3.4 (a): ...".
  const std::string banner = "// ---- Step " + step;
  int sections = 0, complete = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.rfind(banner, 0) != 0 || l.size() <= banner.size() ||
        (l[banner.size()] != ':' && l.compare(banner.size(), 2, " (") != 0))
      continue;
    ++sections;
    // The function's opening line, then its body up to the closing "}".
    std::size_t k = i + 1;
    while (k < lines.size() && (lines[k].empty() || lines[k].rfind("//", 0) == 0)) ++k;
    if (k == lines.size() || !ends_with(lines[k], "{")) continue;
    // Statements on pairs of doubles (jrgen/simd.hpp) do every operation
    // twice, once per lane: "jr::store2(L + 54, (... ) * Dinv[6]);", and the
    // partial sums "jr::v2d s = ...; s += ...;" before such a store.  The
    // pointer offsets "L + 54" inside jr::load2()/jr::store2() are addresses,
    // not arithmetic.
    static const std::regex address(R"(jr::(load2|store2)\(\w+ \+ \d+)");
    bool pair_sum = false;
    for (++k; k < lines.size() && lines[k] != "}"; ++k) {
      std::string line = lines[k];
      if (const std::size_t c = line.find("//"); c != std::string::npos) line.resize(c);
      if (count_dense_kernel(line, &rc)) continue;
      if (contains(line, "PivotTolerance")) continue;  // kMassPivotTolerance, kPivotTolerance
      const bool opens_pair_sum = contains(line, "jr::v2d ");
      const bool stores_pair = contains(line, "jr::store2(");
      const long long lanes = opens_pair_sum || stores_pair || pair_sum ? 2 : 1;
      pair_sum = (pair_sum || opens_pair_sum) && !stores_pair;
      line = std::regex_replace(line, address, "jr::$1(p");
      for (std::size_t p = 0; p < line.size(); ++p) {
        if (line.compare(p, 10, "std::sqrt(") == 0) {
          ++rc.sqrt;
          p += 9;
          continue;
        }
        const char ch = line[p];
        if (ch != '+' && ch != '-' && ch != '*' && ch != '/') continue;
        const bool compound = p + 1 < line.size() && line[p + 1] == '=';
        const bool binary = p > 0 && line[p - 1] == ' ' && p + 1 < line.size() && line[p + 1] == ' ';
        if (!compound && !binary) continue;
        if (ch == '+' || ch == '-') rc.add += lanes;
        else if (ch == '*') rc.mul += lanes;
        else rc.div += lanes;
      }
    }
    if (k < lines.size()) ++complete;
    i = k;
  }
  rc.found = sections > 0 && complete == sections;
  return rc;
}

struct Generated {
  std::string cpp, hpp, report;
  OpTable table;
};

void generate(const std::vector<std::string>& args, Generated* g) {
  ScratchDir scratch("jrgen_report");
  std::vector<std::string> full = args;
  full.insert(full.end(), {"-o", "solver.cpp", "--report", "OPS.md"});
  const RunResult r = run_jrgen(full, scratch.path());
  ASSERT_EQ(r.status, 0) << r.command << "\n" << r.err;
  g->cpp = slurp(scratch / "solver.cpp");
  g->hpp = slurp(scratch / "solver.hpp");
  g->report = slurp(scratch / "OPS.md");
  parse_report(g->report, &g->table);
}

void expect_counts(const OpTable& t, const char* step, long long a, long long m, long long d, long long sq) {
  EXPECT_EQ(t.at("A", step), a) << "A in step " << step;
  EXPECT_EQ(t.at("M", step), m) << "M in step " << step;
  EXPECT_EQ(t.at("D", step), d) << "D in step " << step;
  EXPECT_EQ(t.at("SQ", step), sq) << "SQ in step " << step;
}

struct ReportCase {
  std::vector<std::string> inputs;  // model path [--cuts path]
  std::string method;
  std::string name;
  bool divide = false;  // --divide
};

std::vector<ReportCase> report_cases() {
  std::vector<ReportCase> cases;
  for (const std::string method : {"llt", "ldlt"}) {
    // Trees.
    for (const std::string m : {"arm7", "legged30", "hmmwv14", "stewart"})
      cases.push_back({{(kModelsDir / (m + ".urdf")).string()}, method, m + "_" + method});
    for (const std::string m : {"pendulum", "double_pendulum"})
      cases.push_back({{(kCliDir / (m + ".urdf")).string()}, method, m + "_" + method});
    // Closed loops.
    for (const std::string m : {"hmmwv14", "stewart"})
      cases.push_back({{(kModelsDir / (m + ".urdf")).string(), "--cuts", (kModelsDir / (m + ".cuts.xml")).string()},
                       method,
                       m + "_cuts_" + method});
    for (const std::string m : {"fourbar", "slider_crank"})
      cases.push_back({{(kModelsDir / (m + ".urdf")).string()}, method, m + "_" + method});
    // --divide: a tree with paired rows, the dense and the unrolled Step 3.4.
    cases.push_back({{(kModelsDir / "legged30.urdf").string()}, method, "legged30_divide_" + method, true});
    cases.push_back({{(kCliDir / "double_pendulum.urdf").string()}, method, "double_pendulum_divide_" + method, true});
    cases.push_back({{(kModelsDir / "hmmwv14.urdf").string(), "--cuts", (kModelsDir / "hmmwv14.cuts.xml").string()},
                     method, "hmmwv14_cuts_divide_" + method, true});
    cases.push_back({{(kModelsDir / "fourbar.urdf").string()}, method, "fourbar_divide_" + method, true});
  }
  return cases;
}

void PrintTo(const ReportCase& c, std::ostream* os) { *os << c.name; }

class CliReport : public ::testing::TestWithParam<ReportCase> {};

TEST_P(CliReport, CountsMatchTheEmittedCode) {
  const ReportCase& c = GetParam();
  std::vector<std::string> args = c.inputs;
  args.insert(args.end(), {"--method", c.method});
  if (c.divide) args.push_back("--divide");
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate(args, &g));
  const int nv = header_constant(g.hpp, "nv");
  const int nc = header_constant(g.hpp, "nc");
  ASSERT_GT(nv, 0) << g.hpp;
  ASSERT_GE(nc, 0) << g.hpp;
  for (const char* step : kSteps) {
    SCOPED_TRACE(std::string("step ") + step);
    const Recount rc = recount_step(g.cpp, step);
    const bool tree_step = std::string(step) == "1" || std::string(step) == "2" || std::string(step) == "4";
    if (tree_step || nc > 0) {
      ASSERT_TRUE(rc.found) << "no function after '// ---- Step " << step << ":' in the emitted code";
    }
    // With no constraints, Steps 3.x are not emitted and cost nothing.
    if (!rc.found) {
      EXPECT_EQ(nc, 0);
    }
    expect_counts(g.table, step, rc.add, rc.mul, rc.div, rc.sqrt);
  }
  // One pivot per column: one reciprocal each, and one square root each
  // for L L^T (none for the square-root-free L D L^T).  With --divide, one
  // division per entry of L below the diagonal instead, and one per row in
  // Step 4 (and in Step 2 for L L^T; L D L^T's Step 2 has a unit diagonal).
  EXPECT_EQ(g.table.at("SQ", "1"), c.method == "llt" ? nv : 0);
  if (c.divide) {
    std::smatch m;
    ASSERT_TRUE(std::regex_search(g.report, m, std::regex("stored entries of L = ([0-9]+)"))) << g.report;
    EXPECT_EQ(g.table.at("D", "1"), std::stoll(m[1]) - nv);
    EXPECT_EQ(g.table.at("D", "2"), c.method == "llt" ? nv : 0);
    EXPECT_EQ(g.table.at("D", "4"), nv);
    // (Dinv[j] then holds the pivot itself, for the digits test check_digits_M.)
    EXPECT_FALSE(contains(g.cpp, "Dinv[0] = 1.0 / d") || contains(g.cpp, "Dinv[0] = l * (1.0 / d)"))
        << "--divide: no reciprocal pivots of M";
    EXPECT_TRUE(contains(g.cpp, "Dinv[0] = d;")) << "--divide: the pivots for check_digits_M";
  } else {
    EXPECT_EQ(g.table.at("D", "1"), nv);
    for (const char* step : {"2", "4"})
      EXPECT_EQ(g.table.at("D", step), 0) << "Steps 2 and 4 multiply by the stored reciprocals";
  }
  for (const char* step : {"2", "4"}) EXPECT_EQ(g.table.at("SQ", step), 0);
  EXPECT_TRUE(contains(g.report, "nv = " + std::to_string(nv))) << g.report;
}

std::string report_case_name(const ::testing::TestParamInfo<ReportCase>& info) { return info.param.name; }

INSTANTIATE_TEST_SUITE_P(Models, CliReport, ::testing::ValuesIn(report_cases()), report_case_name);

// Counts derived by hand from the code jrgen emits for tests/cli/pendulum.urdf
// (one revolute joint, nv = 1, packed L has the single entry L[0]).  The pivot
// guard `if (!(d > kPivotTolerance * L[0])) ...` is a test, not arithmetic of
// the factorization, and is not counted.
//
// L L^T:
//   Step 1:  const double d = L[0];            -
//            const double l = std::sqrt(d);    1 SQ
//            L[0] = l;                         -
//            Dinv[0] = l * (1.0 / d);          1 M, 1 D
//   Step 2:  z[0] *= Dinv[0];                  1 M
//   Step 4:  z[0] *= Dinv[0];                  1 M
//   Total:   A 0, M 3, D 1, SQ 1.
// L D L^T:
//   Step 1:  L[0] = d;  Dinv[0] = 1.0 / d;     1 D
//   Step 2:  (unit diagonal, one row: nothing)  -
//   Step 4:  z[0] = z[0] * Dinv[0];            1 M
//   Total:   A 0, M 1, D 1, SQ 0.
TEST(CliReportByHand, PendulumLLT) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({kPendulum}, &g));
  expect_counts(g.table, "1", 0, 1, 1, 1);
  expect_counts(g.table, "2", 0, 1, 0, 0);
  expect_counts(g.table, "4", 0, 1, 0, 0);
  for (const char* step : {"3.1", "3.2", "3.3", "3.4", "3.5"}) expect_counts(g.table, step, 0, 0, 0, 0);
  EXPECT_EQ(g.table.counts[0][8], 0);  // A
  EXPECT_EQ(g.table.counts[1][8], 3);  // M
  EXPECT_EQ(g.table.counts[2][8], 1);  // D
  EXPECT_EQ(g.table.counts[3][8], 1);  // SQ
}

TEST(CliReportByHand, PendulumLDLT) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({kPendulum, "--method", "ldlt"}, &g));
  expect_counts(g.table, "1", 0, 0, 1, 0);
  expect_counts(g.table, "2", 0, 0, 0, 0);
  expect_counts(g.table, "4", 0, 1, 0, 0);
  for (const char* step : {"3.1", "3.2", "3.3", "3.4", "3.5"}) expect_counts(g.table, step, 0, 0, 0, 0);
  EXPECT_EQ(g.table.counts[0][8], 0);
  EXPECT_EQ(g.table.counts[1][8], 1);
  EXPECT_EQ(g.table.counts[2][8], 1);
  EXPECT_EQ(g.table.counts[3][8], 0);
}

// tests/cli/double_pendulum.urdf: a chain of two joints.  In Lemma 2 order the
// child (elbow) is column 0 and the parent (shoulder) column 1; packed L
// holds L[0] = (0,0), L[1] = (1,0), L[2] = (1,1).  Pivot guards not counted.
//
// L L^T:
//   Step 1, column 0:  l = std::sqrt(d); L[0] = l           1 SQ
//                      Dinv[0] = l * (1.0 / d)              1 M, 1 D
//                      L[1] *= Dinv[0]                      1 M
//           column 1:  d = L[2] - L[1] * L[1]               1 A, 1 M
//                      l = std::sqrt(d); L[2] = l           1 SQ
//                      Dinv[1] = l * (1.0 / d)              1 M, 1 D
//                      Step 1: A 1, M 4, D 2, SQ 2.
//   Step 2:  z[0] *= Dinv[0]                                1 M
//            z[1] = (z[1] - L[1] * z[0]) * Dinv[1]          1 A, 2 M
//                      Step 2: A 1, M 3.
//   Step 4:  z[1] *= Dinv[1]                                1 M
//            z[0] = (z[0] - L[1] * z[1]) * Dinv[0]          1 A, 2 M
//                      Step 4: A 1, M 3.
//   Total: A 3, M 10, D 2, SQ 2.
// L D L^T:
//   Step 1, column 0:  Dinv[0] = 1.0 / d                    1 D
//                      L[1] *= Dinv[0]                      1 M
//           column 1:  w0 = L[1] * L[0]                     1 M
//                      d = L[2] - w0 * L[1]                 1 A, 1 M
//                      Dinv[1] = 1.0 / d                    1 D
//                      Step 1: A 1, M 3, D 2, SQ 0.
//   Step 2:  z[1] = z[1] - L[1] * z[0]                      1 A, 1 M
//   Step 4:  z[1] = z[1] * Dinv[1]                          1 M
//            z[0] = z[0] * Dinv[0] - L[1] * z[1]            1 A, 2 M
//                      Step 4: A 1, M 3.
//   Total: A 3, M 7, D 2, SQ 0.
// --divide, L L^T (each entry divided by its pivot; no Dinv):
//   Step 1, column 0:  l = std::sqrt(d); L[0] = l; L[1] /= l     1 SQ, 1 D
//           column 1:  d = L[2] - L[1] * L[1]                   1 A, 1 M
//                      l = std::sqrt(d); L[2] = l               1 SQ
//                      Step 1: A 1, M 1, D 1, SQ 2.
//   Step 2:  z[0] /= L[0]; z[1] = (z[1] - L[1] * z[0]) / L[2]  1 A, 1 M, 2 D
//   Step 4:  z[1] /= L[2]; z[0] = (z[0] - L[1] * z[1]) / L[0]  1 A, 1 M, 2 D
//   Total: A 3, M 3, D 5, SQ 2.
// --divide, L D L^T (L[1] stays unscaled, W[1,0] = L[1,0] D[0], until column 1):
//   Step 1, column 1:  l0 = L[1] / L[0]                     1 D
//                      d = L[2] - L[1] * l0                 1 A, 1 M
//                      Step 1: A 1, M 1, D 1, SQ 0.
//   Step 2:  z[1] = z[1] - L[1] * z[0]                      1 A, 1 M
//   Step 4:  z[1] = z[1] / L[2]                             1 D
//            z[0] = z[0] / L[0] - L[1] * z[1]               1 A, 1 M, 1 D
//   Total: A 3, M 3, D 3, SQ 0.
TEST(CliReportByHand, DoublePendulumLLT) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({(kCliDir / "double_pendulum.urdf").string()}, &g));
  expect_counts(g.table, "1", 1, 4, 2, 2);
  expect_counts(g.table, "2", 1, 3, 0, 0);
  expect_counts(g.table, "4", 1, 3, 0, 0);
  EXPECT_EQ(g.table.counts[0][8], 3);
  EXPECT_EQ(g.table.counts[1][8], 10);
  EXPECT_EQ(g.table.counts[2][8], 2);
  EXPECT_EQ(g.table.counts[3][8], 2);
}

TEST(CliReportByHand, DoublePendulumLDLT) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({(kCliDir / "double_pendulum.urdf").string(), "--method", "ldlt"}, &g));
  expect_counts(g.table, "1", 1, 3, 2, 0);
  expect_counts(g.table, "2", 1, 1, 0, 0);
  expect_counts(g.table, "4", 1, 3, 0, 0);
  EXPECT_EQ(g.table.counts[0][8], 3);
  EXPECT_EQ(g.table.counts[1][8], 7);
  EXPECT_EQ(g.table.counts[2][8], 2);
  EXPECT_EQ(g.table.counts[3][8], 0);
}

TEST(CliReportByHand, DoublePendulumLLTDivide) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({(kCliDir / "double_pendulum.urdf").string(), "--divide"}, &g));
  expect_counts(g.table, "1", 1, 1, 1, 2);
  expect_counts(g.table, "2", 1, 1, 2, 0);
  expect_counts(g.table, "4", 1, 1, 2, 0);
  EXPECT_EQ(g.table.counts[1][8], 3);
  EXPECT_EQ(g.table.counts[2][8], 5);
}

TEST(CliReportByHand, DoublePendulumLDLTDivide) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(
      generate({(kCliDir / "double_pendulum.urdf").string(), "--method", "ldlt", "--divide"}, &g));
  expect_counts(g.table, "1", 1, 1, 1, 0);
  expect_counts(g.table, "2", 1, 1, 0, 0);
  expect_counts(g.table, "4", 1, 1, 2, 0);
  EXPECT_EQ(g.table.counts[1][8], 3);
  EXPECT_EQ(g.table.counts[2][8], 3);
}

// Issue 3's goal for the HMMWV: below the paper's Alg-S (Table 2) in every
// row.  With the paper's arithmetic (--divide: it divides by pivots) and no
// square roots (L D L^T), the emitted code is, although it also counts the two
// triangular solves for lambda that Table 2 leaves out of Step 3.4.
TEST(CliReportByHand, HmmwvLDLTDivideIsBelowAlgSInEveryRow) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({(kModelsDir / "hmmwv14.urdf").string(), "--cuts",
                                    (kModelsDir / "hmmwv14.cuts.xml").string(), "--method", "ldlt", "--divide"},
                                   &g));
  const long long alg_s[4] = {3871, 4258, 513, 43};
  for (std::size_t r = 0; r < kRows.size(); ++r) EXPECT_LT(g.table.counts[r][8], alg_s[r]) << kRows[r];
}

// The same double pendulum with the runtime's table-driven Steps 1, 2, 4
// (internal, test-only JRGEN_UNROLL_LIMIT=0): the counts of the loops of
// runtime/src/runtime.cpp, by hand.  factor_packed, per column: dinv = 1 / d
// (1 D); L L^T: l = sqrt(d) (1 SQ), its scale l * dinv (1 M); per ancestor
// row f = w * dinv (1 M), the update (1 M, 1 A per product), the scaling of
// the row (1 M).  forward_packed / backward_packed: two partial sums per row,
// added at the end (1 A per row), one product and subtraction per entry, and
// the scalings by Dinv as in the straight-line code.
//   L L^T:  Step 1  col 0: D, SQ, M (scale), M (f), M + A (update), M (row)
//                   col 1: D, SQ, M (scale)             A 1, M 5, D 2, SQ 2
//           Step 2  row 0: A, M;  row 1: M + A, A, M    A 3, M 3
//           Step 4  col 1: A, M;  col 0: M + A, A, M    A 3, M 3
//   L D L^T: Step 1 col 0: D, M (f), M + A, M (row); col 1: D   A 1, M 3, D 2
//           Step 2  row 0: A;  row 1: M + A, A          A 3, M 1
//           Step 4  col 1: M, A;  col 0: M, M + A, A    A 3, M 3
class TableDriven : public ::testing::Test {
 protected:
  void SetUp() override { setenv("JRGEN_UNROLL_LIMIT", "0", 1); }
  void TearDown() override { unsetenv("JRGEN_UNROLL_LIMIT"); }
};

TEST_F(TableDriven, DoublePendulumLLTCountsTheRuntimeLoops) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({(kCliDir / "double_pendulum.urdf").string()}, &g));
  ASSERT_TRUE(contains(g.cpp, "jr::factor_packed(")) << "not the table-driven shape";
  expect_counts(g.table, "1", 1, 5, 2, 2);
  expect_counts(g.table, "2", 3, 3, 0, 0);
  expect_counts(g.table, "4", 3, 3, 0, 0);
}

TEST_F(TableDriven, DoublePendulumLDLTCountsTheRuntimeLoops) {
  Generated g;
  ASSERT_NO_FATAL_FAILURE(generate({(kCliDir / "double_pendulum.urdf").string(), "--method", "ldlt"}, &g));
  ASSERT_TRUE(contains(g.cpp, "jr::factor_packed(")) << "not the table-driven shape";
  expect_counts(g.table, "1", 1, 3, 2, 0);
  expect_counts(g.table, "2", 3, 1, 0, 0);
  expect_counts(g.table, "4", 3, 3, 0, 0);
}

// The recount itself, on a hand-written snippet.
TEST(CliReportByHand, RecountCountsWhatItShould) {
  const std::string code =
      "// ---- Step 9: test ----\n"
      "// Ops: whatever\n"
      "void f(double* L, const double* z) {\n"
      "  // row 0: a comment with a - b * c / d\n"
      "  const double d = L[2] - (L[1] * L[1] + L[0] * -L[3]);\n"
      "  if (!(d > kPivotTolerance * L[2])) return fail(0, d);\n"
      "  L[0] = std::sqrt(d) / 2.0 + 1e-3;  // trailing * comment\n"
      "  L[1] *= z[0]; L[2] -= z[1]; L[3] /= z[2]; L[4] += z[3];\n"
      "}\n";
  const Recount rc = recount_step(code, "9");
  EXPECT_TRUE(rc.found);
  EXPECT_EQ(rc.add, 5);  // - + (binary), + (binary), -=, +=; not the unary minus or 1e-3
  EXPECT_EQ(rc.mul, 3);
  EXPECT_EQ(rc.div, 2);
  EXPECT_EQ(rc.sqrt, 1);
}

// ===========================================================================
// Closed loops: notes and errors of the constraint analysis (docs/interface.md
// section 2; fixtures in tests/cli/)
// ===========================================================================

const fs::path kFourbar = kModelsDir / "fourbar.urdf";

// The planar four-bar closed by a 3-D revolute cut: 3 of the 5 rows are
// redundant, dropped with one note naming the file, the loop joint's line and
// the loop joint; the solver is still written.
TEST(CliLoops, FourbarRedundantRowsAreANote) {
  const int line = line_of(kFourbar, "<loop_joint name=\"joint_D\"");
  ASSERT_GT(line, 0);
  ScratchDir scratch("jrgen_cli");
  const RunResult r = run_jrgen({kFourbar.string(), "-o", (scratch / "solver.cpp").string()}, scratch.path());
  SCOPED_TRACE(r.command);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_TRUE(fs::exists(scratch / "solver.cpp"));
  EXPECT_TRUE(fs::exists(scratch / "solver.hpp"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "expected exactly one note:\n" << r.err;
  EXPECT_TRUE(ends_with(r.err, "\n")) << r.err;
  EXPECT_EQ(r.err.rfind("jrgen: note:", 0), 0u) << r.err;
  EXPECT_TRUE(contains(r.err, "fourbar.urdf:" + std::to_string(line) + ":")) << r.err;
  EXPECT_TRUE(contains(r.err, kFourbar.string() + ":" + std::to_string(line) + ":")) << r.err;
  EXPECT_TRUE(contains(r.err, "'joint_D'")) << r.err;
  EXPECT_TRUE(contains(r.err, "3 of its 5 rows")) << r.err;
  EXPECT_TRUE(contains(slurp(scratch / "solver.hpp"), "inline constexpr int nc = 2;"));
}

TEST(CliLoops, FourbarStrictConstraintsIsAnError) {
  const int line = line_of(kFourbar, "<loop_joint name=\"joint_D\"");
  ASSERT_GT(line, 0);
  expect_clean_failure({{kFourbar.string(), "-o", "@OUT@/solver.cpp", "--strict-constraints"},
                        {kFourbar.string() + ":" + std::to_string(line) + ":", "'joint_D'", "redundant",
                         "leave the option out to let jrgen drop them"},
                        {}});
  // The option may come first as well.
  expect_clean_failure({{"--strict-constraints", kFourbar.string(), "-o", "@OUT@/solver.cpp"},
                        {"'joint_D'", "redundant"},
                        {}});
}

// A loop no configuration closes: the tip of a 1 m arm asked to reach 2 m.
TEST(CliLoops, InconsistentLoopCannotBeClosed) {
  const fs::path model = kCliDir / "inconsistent_loop.urdf";
  const int line = line_of(model, "<loop_joint name=\"too_far\"");
  ASSERT_GT(line, 0);
  expect_clean_failure({{model.string(), "-o", "@OUT@/solver.cpp", "--report", "@OUT@/OPS.md"},
                        {model.string() + ":" + std::to_string(line) + ":", "'too_far'", "cannot be closed"},
                        {}});
}

// A distance cut without <distance value> whose frames coincide at the zero
// configuration: the default distance would be 0.
TEST(CliLoops, DistanceCutWithCoincidentFramesNeedsAValue) {
  const fs::path model = kCliDir / "coincident_distance.urdf";
  const int line = line_of(model, "<loop_joint name=\"rod\"");
  ASSERT_GT(line, 0);
  expect_clean_failure({{model.string(), "-o", "@OUT@/solver.cpp"},
                        {model.string() + ":" + std::to_string(line) + ":", "'rod'", "<distance"},
                        {}});
}

// A cut between two links welded by a fixed joint constrains nothing.
TEST(CliLoops, CutWithinOneRigidBody) {
  const fs::path model = kCliDir / "same_body_loop.urdf";
  const int line = line_of(model, "<loop_joint name=\"useless\"");
  ASSERT_GT(line, 0);
  expect_clean_failure({{model.string(), "-o", "@OUT@/solver.cpp"},
                        {model.string() + ":" + std::to_string(line) + ":", "'useless'"},
                        {}});
}

}  // namespace
}  // namespace jrgen::cli_testing
