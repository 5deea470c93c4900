// write_test_model NAME OUT.urdf [OUT.cuts.xml]: writes the test model case
// NAME (tests/common/model_cases) to files, so that the build can generate a
// solver for exactly the text the tests compare against.
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include "common/model_cases.hpp"

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    std::fprintf(stderr, "usage: write_test_model NAME OUT.urdf [OUT.cuts.xml]\n");
    return 2;
  }
  const std::string name = argv[1];
  try {
    const jrgen::testing::ModelCase& c = jrgen::testing::find_model_case(name);
    std::ofstream out(argv[2], std::ios::binary);
    out << c.urdf;
    if (argc == 4) {
      std::ofstream cuts(argv[3], std::ios::binary);
      cuts << c.cuts;
      if (!cuts) return 1;
    }
    return out ? 0 : 1;
  } catch (const std::runtime_error&) {
  }
  std::fprintf(stderr, "write_test_model: no model case named '%s'\n", name.c_str());
  return 1;
}
