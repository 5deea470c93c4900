// Straight-line programs under construction (internal to the emit stage): the
// kinematics and dynamics terms of one model, written as scalar operations on
// the inputs (q, v, tau) and on constants known at generation time.
//
// Every operation goes through Program, which
//   - folds constants: 0 * x = 0, 1 * x = x, x + 0 = x, c1 op c2 = its value,
//     so a zero of a joint axis, an identity rotation or a zero offset
//     vanishes from the code (issue 20: "everything known at generation time
//     folded in");
//   - shares values: the same operation on the same operands is one node
//     (hash-consing), so sin(q[3]) or a transform used by several blocks is
//     computed once;
//   - emits only what the outputs need, in demand order, one statement per
//     node ("const double tN = a * b;"), in functions of bounded size; a value
//     used in a later function is passed through a spill array;
//   - writes the same text whatever order the nodes were created in: C++
//     leaves the order of evaluation of a call's arguments (a * b + c * d)
//     unspecified, and GCC and Clang differ, so the order, the names tN, the
//     spill slots and the operand order of a + b and a * b follow the
//     structure of the program (a hash of each node's expression) and the
//     order of the outputs, never the order of creation;
//   - counts the operations of what it emits, per block (--report).
// Folding x * 0 = 0 assumes finite operands: the generated API tests its
// inputs for NaN and infinity before it runs a program.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

#include "emit/emitter.hpp"

namespace jrgen::emit {

class Program;

/// A scalar of a Program: a constant, or a node of the program.
class Value {
 public:
  Value() = default;
  Value(double c) : c_(c) {}  // NOLINT: constants mix freely with nodes
  bool is_constant() const { return node_ < 0; }
  bool is(double c) const { return is_constant() && c_ == c; }
  double constant() const { return c_; }
  int node() const { return node_; }
  Program* program() const { return p_; }

 private:
  friend class Program;
  Value(Program* p, int node) : p_(p), node_(node) {}
  Program* p_ = nullptr;
  int node_ = -1;
  double c_ = 0.0;
};

Value operator+(Value a, Value b);
Value operator-(Value a, Value b);
Value operator*(Value a, Value b);
Value operator/(Value a, Value b);
Value operator-(Value a);
inline Value& operator+=(Value& a, Value b) { return a = a + b; }
inline Value& operator-=(Value& a, Value b) { return a = a - b; }
Value sqrt(Value a);
Value sin(Value a);
Value cos(Value a);

class Program {
 public:
  enum class Op : std::uint8_t { kInput, kAdd, kSub, kMul, kDiv, kNeg, kSqrt, kSin, kCos };

  /// `params`: the parameter list shared by every emitted function
  /// ("const double* q, double* L"); `spill`: the name of the array that
  /// carries values from one function to a later one.
  Program(std::string params, std::string spill = "g_spill");
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;

  /// A value read from the inputs, written as `expr` wherever it is used
  /// ("q[3]"): no statement of its own.
  Value input(const std::string& expr);

  /// Starts a new emitted function `name` (a valid identifier, unique);
  /// later nodes and outputs belong to it.  Functions that outgrow
  /// max_statements continue in `name_2`, `name_3`, ..., split at the next
  /// comment() or output() (sequenced points: the split does not depend on
  /// the order of creation).
  void begin_function(const std::string& name, const std::string& doc);
  /// Starts a block for the operation counts ("kinematics", "M", ...).
  void begin_block(const std::string& name);
  /// A comment line, written before the first emitted statement of the nodes
  /// created after it (up to the next comment or output; if those are none of
  /// its function's statements, any later node of its function; at the
  /// function's end if there is none).
  void comment(const std::string& text);

  /// "target = value;" (target an lvalue expression such as "L[12]").
  void output(const std::string& target, Value value);
  /// "target += value;" (nothing when value is the constant 0).
  void accumulate(const std::string& target, Value value);

  Value make(Op op, Value a, Value b = Value());

  struct Emitted {
    std::string definitions;          ///< the functions, in order
    std::vector<std::string> calls;   ///< their names, in the order to call them
    int spills = 0;                   ///< size of the spill array
    std::vector<std::pair<std::string, OpCount>> block_ops;  ///< per block, in order
    OpCount total;
    long long statements = 0;
    /// false when a constant of the code is not finite (a URDF's huge but
    /// representable numbers overflowing in a derived constant): the code
    /// would not compile, and the caller takes the runtime's route.
    bool finite = true;
  };
  /// The live nodes (those the outputs need), as functions.  `prefix` starts
  /// each function's text (e.g. an attribute).
  Emitted emit(const std::string& prefix = "") const;

  /// Every node's value with the inputs given by `input(expr)`, in double
  /// precision and the operation order of the emitted code: what the
  /// generated code computes, for tests at generation time (value()).
  std::vector<double> evaluate(const std::function<double(const std::string&)>& input) const;
  static double value(Value v, const std::vector<double>& nodes) {
    return v.is_constant() ? v.constant() : nodes[static_cast<std::size_t>(v.node())];
  }

  /// Operation counts per block of the live nodes, without emitting.
  std::vector<std::pair<std::string, OpCount>> count() const;

  /// Statements per emitted function.  Each split stores and reloads the
  /// values that cross it (the HMMWV's terms at 4000: 500 of 6500
  /// statements); one function is faster (docs/benchmarks.md, run 17: the
  /// HMMWV's call 3 % and iCub's 14 % at 16 000), but GCC's compile time
  /// grows faster than linearly above that (talos at 40 000: 2.6x).
  std::size_t max_statements = 16000;
  /// false: x * 0, x * 1, x + 0 and the like stay operations (constants
  /// meet only constants at generation time), so count() gives what the same
  /// program costs without specialization's folding (--report's "before").
  bool fold_identities = true;

 private:
  struct Node {
    Op op;
    Value a, b;
    std::string text;  // kInput
    int function = 0;
    int block = 0;
    std::uint64_t hash = 0;  // of the expression: the same whatever the creation order
  };
  struct Output {
    std::string target;
    Value value;
    bool accumulate;
    int function;
    int after_node;  // nodes_.size() when it was made
  };
  struct Comment {
    std::string text;
    int function;
    int after_node;  // nodes_.size() when it was made
  };
  struct Event {  // one line of emit()'s text, in order: exactly one index is >= 0
    int node = -1, output = -1, comment = -1;
  };
  struct Function {
    std::string name, doc;
  };

  std::string key(Op op, Value a, Value b) const;
  std::uint64_t hash_of(Value v) const;
  std::vector<bool> live() const;
  std::vector<Event> events(const std::vector<bool>& is_live) const;
  std::string operand(Value v, const std::vector<int>& name) const;
  std::string expression(const Node& n, const std::vector<int>& name) const;
  void split_if_full();

  std::string params_, spill_;
  std::vector<Node> nodes_;
  std::vector<Output> outputs_;
  std::vector<Comment> comments_;
  std::vector<Function> functions_;
  std::vector<std::string> blocks_;
  std::vector<std::size_t> function_nodes_;  // nodes created in each function
  std::string base_name_, base_doc_;
  int parts_ = 1;
  std::unordered_map<std::string, int> index_;
  mutable bool non_finite_ = false;  // set by operand() on a constant inf or nan
};

// ---- 3-vectors and 3x3 matrices of Values -------------------------------------

using Vec3 = std::array<Value, 3>;
using Mat3 = std::array<Value, 9>;  ///< row-major

Vec3 vec3(const Eigen::Vector3d& v);
Mat3 mat3(const Eigen::Matrix3d& m);
Mat3 identity3();
Vec3 operator+(const Vec3& a, const Vec3& b);
Vec3 operator-(const Vec3& a, const Vec3& b);
Vec3 operator*(Value s, const Vec3& a);
Value dot(const Vec3& a, const Vec3& b);
Vec3 cross(const Vec3& a, const Vec3& b);
Vec3 mul(const Mat3& R, const Vec3& x);    ///< R x
Vec3 tmul(const Mat3& R, const Vec3& x);   ///< R^T x
Mat3 mul(const Mat3& A, const Mat3& B);    ///< A B
Mat3 transpose(const Mat3& A);

}  // namespace jrgen::emit
