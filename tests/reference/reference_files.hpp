// Reading the committed reference trajectories (tests/published/reference/*.tsv,
// tests/simulate/extreme/reference/*.tsv) written by tests/reference/trajectory_reference.cpp
// (SUNDIALS CVODE on the dynamics of tests/reference/; docs/testing.md, "References").
// Format: '#' header lines saying how the file was made, one line of column names
// (t, then q..., v..., ...), then one row per output time, tab-separated.
#pragma once

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace jrgen::reference {

struct ReferenceFile {
  std::string header;              ///< the '#' lines
  std::vector<std::string> names;  ///< column names
  std::vector<std::vector<double>> rows;

  int column(const std::string& name) const {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == name) return static_cast<int>(i);
    throw std::runtime_error("reference file: no column '" + name + "'");
  }
  /// The header's estimate of the reference's own error: the largest difference over
  /// the rows from the same run at a 10 x looser tolerance (an estimate from above).
  double error_estimate() const {
    const std::string key = "differs by at most ";
    const std::size_t i = header.find(key);
    if (i == std::string::npos) throw std::runtime_error("reference file: no error estimate in the header");
    return std::stod(header.substr(i + key.size()));
  }
  /// The row at time t (within 1e-9 s); throws when there is none.
  const std::vector<double>& row_at(double t) const {
    for (const auto& r : rows)
      if (std::abs(r[0] - t) <= 1e-9) return r;
    throw std::runtime_error("reference file: no row at t = " + std::to_string(t));
  }
};

inline ReferenceFile read_reference_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read reference file " + path);
  ReferenceFile r;
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("#", 0) == 0) {
      r.header += line + "\n";
      continue;
    }
    std::istringstream is(line);
    if (r.names.empty()) {
      for (std::string w; is >> w;) r.names.push_back(w);
      continue;
    }
    std::vector<double> row;
    for (double x; is >> x;) row.push_back(x);
    if (row.size() != r.names.size()) throw std::runtime_error("reference file " + path + ": a short row");
    r.rows.push_back(row);
  }
  if (r.rows.empty()) throw std::runtime_error("reference file " + path + ": no rows");
  return r;
}

}  // namespace jrgen::reference
