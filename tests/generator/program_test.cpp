// emit::Program, the straight-line program builder of the specialized
// kinematics and dynamics (issue 20): constant folding, sharing, liveness,
// spills between functions, operation counts.  The numbers the programs
// compute are checked end to end by the generated-solver tests against the
// independent reference; here, the text and the counts.
#include "emit/program.hpp"

#include <gtest/gtest.h>

#include <string>

namespace {

using jrgen::emit::Program;
using jrgen::emit::Value;

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(Program, FoldsConstantsZerosAndOnes) {
  Program p("const double* q, double* out");
  p.begin_function("f", "test");
  p.begin_block("b");
  const Value x = p.input("q[0]");
  EXPECT_TRUE((x * 0.0).is(0.0));
  EXPECT_TRUE((0.0 * x).is(0.0));
  EXPECT_EQ((x * 1.0).node(), x.node());
  EXPECT_EQ((x + 0.0).node(), x.node());
  EXPECT_EQ((0.0 + x).node(), x.node());
  EXPECT_EQ((x - 0.0).node(), x.node());
  EXPECT_TRUE((x - x).is(0.0));
  EXPECT_EQ((-(-x)).node(), x.node());
  EXPECT_TRUE((Value(2.0) * Value(3.0) + Value(1.0)).is(7.0));
  p.output("out[0]", x * 0.0 + 2.0);
  const Program::Emitted e = p.emit();
  EXPECT_NE(e.definitions.find("out[0] = 2.0;"), std::string::npos) << e.definitions;
  EXPECT_EQ(e.total.mul + e.total.add, 0);
}

TEST(Program, SharesRepeatedOperationsAndCommutedOperands) {
  Program p("const double* q, double* out");
  p.begin_function("f", "test");
  p.begin_block("b");
  const Value a = p.input("q[0]"), b = p.input("q[1]");
  const Value s1 = jrgen::emit::sin(a), s2 = jrgen::emit::sin(a);
  EXPECT_EQ(s1.node(), s2.node());
  EXPECT_EQ((a * b).node(), (b * a).node());
  EXPECT_EQ((a + b).node(), (b + a).node());
  EXPECT_NE((a - b).node(), (b - a).node());
  // x + (-y) is x - y; (-x) * y is -(x y).
  EXPECT_EQ((a + -b).node(), (a - b).node());
  EXPECT_EQ(((-a) * b).node(), (-(a * b)).node());
  p.output("out[0]", s1 * b + s2 * b);
  const Program::Emitted e = p.emit();
  EXPECT_EQ(count(e.definitions, "std::sin("), 1) << e.definitions;
  EXPECT_EQ(e.total.trig, 1);
  EXPECT_EQ(e.total.mul, 1);  // sin(a) * b once, then t + t
  EXPECT_EQ(e.total.add, 1);
}

TEST(Program, EmitsOnlyWhatTheOutputsNeed) {
  Program p("const double* q, double* out");
  p.begin_function("f", "test");
  p.begin_block("used");
  const Value a = p.input("q[0]"), b = p.input("q[1]");
  const Value kept = a * b;
  p.begin_block("dead");
  const Value dead = a / b + jrgen::emit::cos(b);
  (void)dead;
  p.output("out[0]", kept);
  const Program::Emitted e = p.emit();
  EXPECT_EQ(count(e.definitions, " / "), 0) << e.definitions;
  EXPECT_EQ(count(e.definitions, "cos"), 0);
  ASSERT_EQ(e.block_ops.size(), 2u);
  EXPECT_EQ(e.block_ops[0].first, "used");
  EXPECT_EQ(e.block_ops[0].second.mul, 1);
  EXPECT_EQ(e.block_ops[1].second.div + e.block_ops[1].second.add + e.block_ops[1].second.trig, 0);
}

TEST(Program, CarriesValuesIntoLaterFunctionsThroughTheSpillArray) {
  Program p("const double* q, double* out", "g_spill");
  p.begin_function("first", "one");
  p.begin_block("b");
  const Value a = p.input("q[0]"), b = p.input("q[1]");
  const Value ab = a * b;
  p.output("out[0]", ab);
  p.begin_function("second", "two");
  p.output("out[1]", ab * ab);
  const Program::Emitted e = p.emit();
  ASSERT_EQ(e.calls.size(), 2u);
  EXPECT_EQ(e.calls[0], "first");
  EXPECT_EQ(e.calls[1], "second");
  EXPECT_EQ(e.spills, 1);
  EXPECT_NE(e.definitions.find("g_spill[0] = t"), std::string::npos) << e.definitions;
  EXPECT_NE(e.definitions.find("= g_spill[0];"), std::string::npos) << e.definitions;
  // "second" never reads q: it is cast to void (-Wunused-parameter).
  EXPECT_NE(e.definitions.find("(void)q;"), std::string::npos);
}

TEST(Program, SplitsFunctionsThatOutgrowTheLimit) {
  Program p("const double* q, double* out");
  p.max_statements = 10;
  p.begin_function("big", "many statements");
  p.begin_block("b");
  Value x = p.input("q[0]");
  for (int i = 0; i < 35; ++i) {
    p.comment(std::to_string(i));  // functions split at comments and outputs
    x = x * x + static_cast<double>(i + 1);
  }
  p.output("out[0]", x);
  const Program::Emitted e = p.emit();
  EXPECT_GE(e.calls.size(), 4u);
  EXPECT_EQ(e.calls[1], "big_2");
  EXPECT_EQ(e.statements, 71);  // 70 operations and the output
}

TEST(Program, OperationsBeforeAFunctionAreAnError) {
  Program p("const double* q");
  EXPECT_THROW(p.input("q[0]") * p.input("q[1]"), std::logic_error);
}

}  // namespace

// C++ leaves the order of evaluation of a call's arguments unspecified (GCC
// and Clang differ), so the same model may create its nodes in different
// orders: the text must not depend on it (program.hpp).
TEST(Program, TextDoesNotDependOnTheOrderOfCreation) {
  auto build = [](bool reversed) {
    Program p("const double* q, double* out", "g_spill");
    p.max_statements = 6;
    p.begin_function("f", "order");
    p.begin_block("b");
    const Value x = p.input("q[0]"), y = p.input("q[1]");
    Value s, c, u;
    p.comment("first part");
    if (reversed) {
      u = y * y + x;
      c = cos(y);
      s = sin(x);
    } else {
      s = sin(x);
      c = cos(y);
      u = x + y * y;
    }
    const Value sc = reversed ? c * s : s * c;
    p.comment("second part");
    const Value w = reversed ? (u * 2.0 + sc) : (sc + 2.0 * u);
    p.output("out[0]", w);
    p.begin_function("g", "later");
    p.output("out[1]", reversed ? u * sc : sc * u);
    return p.emit().definitions;
  };
  const std::string forward = build(false), backward = build(true);
  EXPECT_EQ(forward, backward);
  EXPECT_NE(forward.find("g_spill["), std::string::npos) << forward;  // values cross into g
}
