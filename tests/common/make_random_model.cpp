// make_random_model: write a random URDF for benchmarks.
//
//   make_random_model tree  --seed S --bodies N [--max-depth D] [--floating]
//                           [--mechanism-bodies B] -o FILE.urdf
//   make_random_model chain --seed S --bodies N -o FILE.urdf
//   make_random_model train --vehicles K [--vehicle V.urdf --vehicle-cuts V.cuts.xml] -o FILE.urdf
//
// "chain" makes a serial revolute chain of N joints.  "--mechanism-bodies B"
// makes the tree a scene of many small mechanisms of B bodies each, all on
// the world (RandomTreeOptions::mechanism_bodies).  "-o -" writes to stdout.
// "train" makes K copies of a vehicle (default: models/hmmwv14.urdf and its
// cuts), hitched by spherical cut joints (random_model.hpp, vehicle_train);
// it writes FILE.urdf and the cuts beside it, FILE.cuts.xml.
#include "random_model.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

namespace {

[[noreturn]] void usage(const char* msg) {
  if (msg) std::fprintf(stderr, "make_random_model: %s\n", msg);
  std::fprintf(stderr,
               "usage: make_random_model tree|chain --seed S --bodies N [--max-depth D] [--floating]\n"
               "                         [--mechanism-bodies B] -o FILE.urdf\n"
               "       make_random_model train --vehicles K [--vehicle V.urdf --vehicle-cuts V.cuts.xml] -o FILE.urdf\n");
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

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) std::fprintf(stderr, "make_random_model: cannot write %s\n", path.c_str());
  return static_cast<bool>(out);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "make_random_model: cannot read %s\n", path.c_str());
    std::exit(1);
  }
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int train_main(int argc, char** argv) {
  long long vehicles = -1;
  std::string output;
#ifdef JRGEN_SOURCE_DIR
  std::string vehicle = std::string(JRGEN_SOURCE_DIR) + "/models/hmmwv14.urdf";
  std::string vehicle_cuts = std::string(JRGEN_SOURCE_DIR) + "/models/hmmwv14.cuts.xml";
#else
  std::string vehicle, vehicle_cuts;
#endif
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) usage((a + " needs a value").c_str());
      return argv[++i];
    };
    if (a == "--vehicles") vehicles = parse_int("--vehicles", value());
    else if (a == "--vehicle") vehicle = value();
    else if (a == "--vehicle-cuts") vehicle_cuts = value();
    else if (a == "-o") output = value();
    else usage(("unknown option '" + a + "' for train").c_str());
  }
  if (vehicles < 1) usage("train needs --vehicles K with K >= 1");
  if (output.empty() || output == "-") usage("train needs -o FILE.urdf (the cuts go beside it)");
  if (vehicle.empty() || vehicle_cuts.empty()) usage("train needs --vehicle and --vehicle-cuts");
  jrgen::testing::ModelWithCuts train;
  try {
    train = jrgen::testing::vehicle_train(static_cast<int>(vehicles), read_file(vehicle), read_file(vehicle_cuts));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_random_model: %s\n", e.what());
    return 2;
  }
  std::filesystem::path cuts = output;
  cuts.replace_extension(".cuts.xml");
  return write_file(output, train.urdf) && write_file(cuts.string(), train.cuts) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h"))) usage(nullptr);
  if (argc < 2) usage("missing kind (tree or chain)");
  const std::string kind = argv[1];
  if (kind == "train") return train_main(argc, argv);
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
    } else if (a == "--mechanism-bodies") {
      options.mechanism_bodies = static_cast<int>(parse_int("--mechanism-bodies", value()));
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
  if (kind == "chain" && (options.floating_base || options.max_depth != 0 || options.mechanism_bodies != 0))
    usage("--floating, --max-depth and --mechanism-bodies apply to 'tree' only");

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
