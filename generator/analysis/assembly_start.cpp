// The start configuration of --assemble-from (docs/assembly.md).
#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/constraints.hpp"
#include "ir/error.hpp"

namespace jrgen::analysis {

std::vector<std::string> coordinate_names(const topology::Tree& tree) {
  std::vector<std::string> names(tree.nq);
  for (const topology::Body& b : tree.bodies)
    for (int k = 0; k < b.nq; ++k) names[b.q_user + k] = b.nq == 1 ? b.joint_name : fmt::format("{}[{}]", b.joint_name, k);
  return names;
}

namespace {

// "nq = 3 numbers (user order: a, b, c)", at most eight names.
std::string expected(const topology::Tree& tree) {
  const std::vector<std::string> names = coordinate_names(tree);
  std::string list;
  for (std::size_t i = 0; i < names.size() && i < 8; ++i) list += (i ? ", " : "") + names[i];
  if (names.size() > 8) list += ", ...";
  return fmt::format("nq = {} numbers (user order: {})", tree.nq, list);
}

}  // namespace

Eigen::VectorXd read_start_configuration(const std::string& path, const topology::Tree& tree) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw Error("--assemble-from " + path + ": cannot read: it is a folder; give the file of nq numbers");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw Error("--assemble-from " + path + ": cannot read: " + std::strerror(err) +
                (err == ENOENT ? "; check the path (relative to the folder jrgen runs in)" : ""));
  }
  std::vector<double> values;
  std::string line;
  for (int line_number = 1; std::getline(in, line); ++line_number) {
    line = line.substr(0, line.find('#'));
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream words(line);
    for (std::string word; words >> word;) {
      char* end = nullptr;
      const double x = std::strtod(word.c_str(), &end);
      if (end != word.c_str() + word.size() || !std::isfinite(x))
        throw Error(ir::SourceLocation{path, line_number}, "", "",
                    fmt::format("'{}' is not a finite number; give {}",
                                word.size() > 40 ? word.substr(0, 40) + "..." : word, expected(tree)));
      values.push_back(x);
    }
  }
  if (static_cast<int>(values.size()) != tree.nq)
    throw Error(ir::SourceLocation{path, 0}, "", "",
                fmt::format("has {} numbers; give {}", values.size(), expected(tree)));
  Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(values.data(), tree.nq);
  for (const topology::Body& b : tree.bodies) {
    if (b.type != ir::JointType::Ball && b.type != ir::JointType::Floating) continue;
    const int at = b.q_user + (b.type == ir::JointType::Floating ? 3 : 0);
    const double norm = q.segment<4>(at).norm();
    if (!(norm > 0.0) || !std::isfinite(norm))
      throw Error(ir::SourceLocation{path, 0}, "", "",
                  fmt::format("numbers {} to {} (the quaternion w x y z of joint '{}') {}; give a rotation",
                              at + 1, at + 4, b.joint_name, norm > 0.0 ? "are too large to normalize" : "are all 0"));
    q.segment<4>(at) /= norm;
  }
  return q;
}

}  // namespace jrgen::analysis
