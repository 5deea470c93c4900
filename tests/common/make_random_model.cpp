// make_random_model: write a random URDF for benchmarks.
//
//   make_random_model tree  --seed S --bodies N [--max-depth D] [--floating] -o FILE.urdf
//   make_random_model chain --seed S --bodies N -o FILE.urdf
//
// "chain" makes a serial revolute chain of N joints.  "-o -" writes to stdout.
#include "random_model.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <string>

namespace {

[[noreturn]] void usage(const char* msg) {
  if (msg) std::fprintf(stderr, "make_random_model: %s\n", msg);
  std::fprintf(stderr,
               "usage: make_random_model tree|chain --seed S --bodies N [--max-depth D] [--floating] -o FILE.urdf\n");
  std::exit(msg ? 2 : 0);
}

long long parse_int(const char* option, const char* text) {
  char* end = nullptr;
  const long long v = std::strtoll(text, &end, 10);
  if (!*text || *end || v < 0) {
    std::fprintf(stderr, "make_random_model: %s needs a non-negative integer, got '%s'\n", option, text);
    std::exit(2);
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h"))) usage(nullptr);
  if (argc < 2) usage("missing kind (tree or chain)");
  const std::string kind = argv[1];
  if (kind != "tree" && kind != "chain") usage(("unknown kind '" + kind + "'").c_str());

  jrgen::testing::RandomTreeOptions options;
  bool have_bodies = false;
  std::string output;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) usage((a + " needs a value").c_str());
      return argv[++i];
    };
    if (a == "--seed") {
      options.seed = static_cast<std::uint64_t>(parse_int("--seed", value()));
    } else if (a == "--bodies") {
      options.num_bodies = static_cast<int>(parse_int("--bodies", value()));
      have_bodies = true;
    } else if (a == "--max-depth") {
      options.max_depth = static_cast<int>(parse_int("--max-depth", value()));
    } else if (a == "--floating") {
      options.floating_base = true;
    } else if (a == "-o") {
      output = value();
    } else if (a == "--help" || a == "-h") {
      usage(nullptr);
    } else {
      usage(("unknown option '" + a + "'").c_str());
    }
  }
  if (!have_bodies) usage("--bodies is required");
  if (output.empty()) usage("-o FILE is required");
  if (kind == "chain" && (options.floating_base || options.max_depth != 0))
    usage("--floating and --max-depth apply to 'tree' only");

  std::string text;
  try {
    text = kind == "tree" ? jrgen::testing::random_tree_urdf(options)
                          : jrgen::testing::chain_urdf(options.num_bodies, options.seed);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_random_model: %s\n", e.what());
    return 2;
  }
  if (output == "-") {
    std::cout << text;
    return std::cout ? 0 : 1;
  }
  std::ofstream out(output, std::ios::binary);
  out << text;
  out.close();
  if (!out) {
    std::fprintf(stderr, "make_random_model: cannot write %s\n", output.c_str());
    return 1;
  }
  return 0;
}
