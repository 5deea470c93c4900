// Text formatting shared by the emitters (internal to the emit stage).
#pragma once

#include <fmt/format.h>

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

#include "topology/topology.hpp"

namespace jrgen::emit {

// Round-trip formatting of model constants (shortest exact representation).
inline std::string num(double x) {
  if (x == 0.0) return "0.0";
  std::string s = fmt::format("{}", x);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

inline std::string vec(const Eigen::Vector3d& v) {
  return fmt::format("{{{}, {}, {}}}", num(v[0]), num(v[1]), num(v[2]));
}

template <typename Range>
std::string join_ints(const Range& values) {
  std::string out;
  for (const auto& v : values) {
    if (!out.empty()) out += ", ";
    out += std::to_string(v);
  }
  return out;
}

// A URDF name inside a C++ string literal: quotes, backslashes and control
// characters escaped (octal), and a '?' after another '?' as "\?" (no two
// '?' in a row: no trigraph, no -Wtrigraphs), so any name compiles.
inline std::string c_string(std::string_view name) {
  std::string out = "\"";
  for (std::size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (c == '"' || c == '\\' || (c == '?' && i > 0 && name[i - 1] == '?')) {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c == 0x7f) {
      out += fmt::format("\\{:03o}", c);
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

// A URDF name inside a // comment: control characters become '?',
// backslashes '/', and "??" becomes "? ?" (no trigraph "??/" to splice the
// next line under -std=c++14), so a name can never end or continue the
// comment line.
inline std::string comment_text(std::string_view name) {
  std::string out;
  for (char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    if (c == '\\') c = '/';
    if (c == '?' && !out.empty() && out.back() == '?') out += ' ';
    out += c;
  }
  return out;
}

inline std::string L(const topology::Tree& t, int row, int col) {
  return fmt::format("L[{}]", t.packed(row, col));
}

// Names a dof for comments: joint 'knee' or joint 'hip' (coordinate 2 of 3).
inline std::string dof_label(const topology::Tree& t, int dof) {
  const topology::Body& b = t.bodies[t.dof_body[dof]];
  if (b.nv == 1) return fmt::format("joint '{}'", comment_text(b.joint_name));
  return fmt::format("joint '{}' (coordinate {} of {})", comment_text(b.joint_name), dof - b.v_lem + 1, b.nv);
}

// A function copying entries of a dense user-order matrix into a packed
// workspace: dst[to[k]] = src[from[k]].  Straight-line when `unrolled`, else
// a loop over constant tables: a side that is the identity (to[k] = k, as
// for packing M and gathering Q) gets no table, and an index table is 32-bit
// when its entries fit.  The narrow, single table halves or thirds the index
// bytes read per entry: packing the dense M of a 1059-dof tree took 3.5 us
// with two tables (32- and 64-bit) and 1.9 us so (docs/benchmarks.md, run 6).
inline std::string gather_function(const std::string& doc, const std::string& name, const std::string& src,
                                   const std::string& dst, const std::vector<long long>& to,
                                   const std::vector<long long>& from, bool unrolled) {
  std::string out = doc + fmt::format("void {}(const double* __restrict {}, double* __restrict {}) {{\n", name, src, dst);
  if (to.empty()) {
    out += fmt::format("  (void){};\n  (void){};\n", src, dst);
  } else if (unrolled) {
    for (std::size_t k = 0; k < to.size(); ++k) out += fmt::format("  {}[{}] = {}[{}];\n", dst, to[k], src, from[k]);
  } else {
    auto index = [&](const std::vector<long long>& table, const char* table_name) -> std::string {
      bool identity = true, narrow = true;
      for (std::size_t k = 0; k < table.size(); ++k) {
        identity = identity && table[k] == static_cast<long long>(k);
        narrow = narrow && table[k] <= 0x7fffffffLL;
      }
      if (identity) return "k";
      out += fmt::format("  static constexpr std::{} {}[{}] = {{ {} }};\n", narrow ? "int32_t" : "int64_t", table_name,
                         table.size(), join_ints(table));
      return fmt::format("{}[k]", table_name);
    };
    const std::string to_index = index(to, "kTo");
    const std::string from_index = index(from, "kFrom");
    out += fmt::format("  for (std::int32_t k = 0; k < {}; ++k) {}[{}] = {}[{}];\n", to.size(), dst, to_index, src,
                       from_index);
  }
  return out + "}";
}

}  // namespace jrgen::emit
