// mark_dispatch (generator/emit/dispatch.cpp): which definitions of a
// generated file get both processor copies.  That the copies exist in a built
// solver, and that their results pass the suite's checks, is ctest
// dispatch_symbols_test and the generated_dispatch_test program.
#include "emit/dispatch.hpp"

#include <gtest/gtest.h>

#include <string>

namespace jrgen::emit {
namespace {

TEST(Dispatch, MarksDefinitionsOfWorkingRoutines) {
  const std::string in =
      "void mass_matrix_part(const double* q, double* M) {\n"
      "  M[0] = q[0];\n"
      "}\n"
      "JRGEN_STEP int step1_factor(double* __restrict L,\n"
      "                            double* __restrict Dinv) {\n"
      "  return 0;\n"
      "}\n"
      "double potential_energy(const double* q) { return q[0]; }\n";
  const std::string out = mark_dispatch(in);
  EXPECT_EQ(out,
            "JRGEN_DISPATCH void mass_matrix_part(const double* q, double* M) {\n"
            "  M[0] = q[0];\n"
            "}\n"
            "JRGEN_DISPATCH JRGEN_STEP int step1_factor(double* __restrict L,\n"
            "                            double* __restrict Dinv) {\n"
            "  return 0;\n"
            "}\n"
            "JRGEN_DISPATCH double potential_energy(const double* q) { return q[0]; }\n");
}

TEST(Dispatch, LeavesDeclarationsErrorPathsAndOtherLinesAlone) {
  const std::string in =
      "int forward_dynamics(const double* q, const double* v, const double* tau, double* qdd,\n"
      "                     double* lambda);\n"
      "int fail(int status, const char* what) {\n"
      "  return status;\n"
      "}\n"
      "const char* last_error() { return g_error; }\n"
      "  void indented(double* x) {\n"
      "// void comment(double* x) {\n"
      "std::int32_t joint_of(const int* first, std::int32_t i) {\n"
      "int not_positive_definite(std::int32_t dof_lem, double pivot) {";
  EXPECT_EQ(mark_dispatch(in), in);
}

TEST(Dispatch, MacroKeepsOneCopyWhenAskedOrAlreadyAvx2) {
  const std::string m = dispatch_macro();
  EXPECT_NE(m.find("!defined(JRGEN_NO_DISPATCH)"), std::string::npos);
  EXPECT_NE(m.find("!defined(__AVX2__)"), std::string::npos);
  EXPECT_NE(m.find("target_clones(\"arch=x86-64-v3\", \"default\")"), std::string::npos);
  EXPECT_NE(m.find("#define JRGEN_DISPATCH\n"), std::string::npos);  // the one-copy branch
}

}  // namespace
}  // namespace jrgen::emit
