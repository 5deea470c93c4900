// Every solver generated for the tests, with its API as function pointers,
// so one test body can run on all of them.  The table itself is written by
// tests/CMakeLists.txt (solver_registry.cpp in the build folder).
#pragma once

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

}  // namespace jrgen::testing
