// libFuzzer target: the URDF reader, the cuts reader, and the stages that run
// on what they accept (topology::build_tree, analysis::analyze_constraints,
// emit::emit_solver and emit::operation_report), as generator/main.cpp runs
// them (default options).  docs/testing.md tells how to run it.
//
// An input is URDF text, optionally followed by kCutsSeparator and the text of
// a --cuts file.  Every outcome but two is a bug the fuzzer reports:
//   - success, or
//   - a jrgen::Error whose message is one non-empty line of printable text
//     (no control characters; docs/conventions.md, "Errors").
// Any other exception is jrgen's "internal error" (exit 2), and is reported
// as a crash (abort), like the sanitizers' findings.
//
// Work per input is bounded so that no input can hang the fuzzer: at most
// kMaxInputBytes of text and, past the readers, at most kMaxLinks links and
// kMaxCuts cut joints (the assembly Newton iteration of analyze_constraints
// is itself bounded, 60 iterations).  The replay (fuzz_replay, compiled with
// JRGEN_FUZZ_REPLAY) runs each seed once, so it lifts these bounds: every
// seed is run whole, the largest models included.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "analysis/constraints.hpp"
#include "emit/emitter.hpp"
#include "emit/report.hpp"
#include "fuzz_input.hpp"
#include "ir/error.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace {

#if defined(JRGEN_FUZZ_REPLAY)
constexpr std::size_t kMaxInputBytes = SIZE_MAX;
constexpr std::size_t kMaxLinks = SIZE_MAX;
constexpr std::size_t kMaxCuts = SIZE_MAX;
#else
constexpr std::size_t kMaxInputBytes = 32 * 1024;
constexpr std::size_t kMaxLinks = 64;
constexpr std::size_t kMaxCuts = 12;
#endif

[[noreturn]] void fail(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_urdf: %s: %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const jrgen::Error& e) {
  const std::string m = e.what();
  bool control = false;
  for (const char c : m) control = control || static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
  if (m.empty() || control) fail("error message is not one non-empty line of printable text", m);
}

void run(const std::string& input) {
  const jrgen::fuzz::Input in = jrgen::fuzz::split_input(input);
  jrgen::ir::Robot robot = jrgen::urdf::read_robot_string(in.urdf, "fuzz.urdf");
  if (in.has_cuts) jrgen::urdf::read_cuts_string(in.cuts, "fuzz.cuts.xml", robot);
  if (robot.links.size() > kMaxLinks || robot.cuts.size() > kMaxCuts) return;
  jrgen::topology::Tree tree = jrgen::topology::build_tree(robot);
  jrgen::analysis::analyze_constraints(robot, tree, /*strict=*/false);
  jrgen::emit::Options options;
  options.name_space = jrgen::emit::sanitize_identifier(robot.name);
  options.source_name = "fuzz.urdf";
  options.cuts_name = in.has_cuts ? "fuzz.cuts.xml" : "";
  options.header_name = "fuzz.hpp";
  const jrgen::emit::Solver solver = jrgen::emit::emit_solver(robot, tree, options);
  jrgen::emit::operation_report(robot, tree, solver);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > kMaxInputBytes) return -1;  // -1: not added to the corpus
  try {
    run(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const jrgen::Error& e) {
    check_message(e);
  } catch (const std::exception& e) {
    fail("internal error (not a jrgen::Error)", e.what());
  }
  return 0;
}
