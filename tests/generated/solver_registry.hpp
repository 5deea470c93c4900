// Every solver generated for the tests, with its API as function pointers,
// so one test body can run on all of them.  The table itself is written by
// tests/CMakeLists.txt (solver_registry.cpp in the build folder).
#pragma once

#include <gtest/gtest.h>

#include <ostream>
#include <string>
#include <vector>

namespace jrgen::testing {

struct GeneratedSolver {
  std::string target;      ///< CMake target and C++ namespace
  std::string model_case;  ///< name in tests/common/model_cases
  std::string method;      ///< "llt" or "ldlt"
  double gravity[3];
  int nq, nv, nc, njoints;
  const char* const* joint_names;
  const int* joint_q_index;
  const int* joint_v_index;
  int (*forward_dynamics)(const double*, const double*, const double*, double*, double*);
  int (*solve_augmented)(const double*, const double*, const double*, const double*, double*, double*);
  void (*mass_matrix)(const double*, double*);
  void (*bias_forces)(const double*, const double*, double*);
  void (*constraints)(const double*, double*);
  void (*constraint_jacobian)(const double*, double*);
  void (*constraint_gamma)(const double*, const double*, double*);
  const char* (*last_error)();
};

const std::vector<GeneratedSolver>& generated_solvers();

/// The solvers of tree model cases (loops false) or of closed-loop ones,
/// whose model case names start with "loops_".
inline std::vector<GeneratedSolver> generated_solvers(bool loops) {
  std::vector<GeneratedSolver> out;
  for (const GeneratedSolver& s : generated_solvers())
    if ((s.model_case.rfind("loops_", 0) == 0) == loops) out.push_back(s);
  return out;
}

/// gtest names and printing.
inline std::string solver_name(const ::testing::TestParamInfo<GeneratedSolver>& info) { return info.param.target; }
inline void PrintTo(const GeneratedSolver& s, std::ostream* os) { *os << s.target; }

}  // namespace jrgen::testing
