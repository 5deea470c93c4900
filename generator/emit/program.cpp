#include "emit/program.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "emit/format.hpp"

namespace jrgen::emit {

namespace {

Program* program_of(Value a, Value b) { return a.program() != nullptr ? a.program() : b.program(); }

std::uint64_t bits(double c) {
  std::uint64_t u;
  std::memcpy(&u, &c, sizeof u);
  return u;
}

// Hashes of expressions (Node::hash), the same on every compiler and library:
// splitmix64's finalizer over a combination, FNV-1a for input texts.
std::uint64_t mix(std::uint64_t h, std::uint64_t x) {
  std::uint64_t z = h ^ (x + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2));
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

// The names of the parameters in "const double* q, double* L".
std::vector<std::string> parameter_names(const std::string& params) {
  std::vector<std::string> names;
  std::size_t start = 0;
  while (start < params.size()) {
    std::size_t end = params.find(',', start);
    if (end == std::string::npos) end = params.size();
    std::string p = params.substr(start, end - start);
    std::size_t last = p.find_last_not_of(' ');
    std::size_t first = p.find_last_of(" *&", last);
    if (last != std::string::npos) names.push_back(p.substr(first + 1, last - first));
    start = end + 1;
  }
  return names;
}

bool uses_name(const std::string& body, const std::string& name) {
  for (std::size_t at = body.find(name); at != std::string::npos; at = body.find(name, at + 1)) {
    const auto ident = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
    const bool before = at > 0 && ident(body[at - 1]);
    const bool after = at + name.size() < body.size() && ident(body[at + name.size()]);
    if (!before && !after) return true;
  }
  return false;
}

}  // namespace

Value operator+(Value a, Value b) { return a.is_constant() && b.is_constant() ? Value(a.constant() + b.constant()) : program_of(a, b)->make(Program::Op::kAdd, a, b); }
Value operator-(Value a, Value b) { return a.is_constant() && b.is_constant() ? Value(a.constant() - b.constant()) : program_of(a, b)->make(Program::Op::kSub, a, b); }
Value operator*(Value a, Value b) { return a.is_constant() && b.is_constant() ? Value(a.constant() * b.constant()) : program_of(a, b)->make(Program::Op::kMul, a, b); }
Value operator/(Value a, Value b) { return a.is_constant() && b.is_constant() ? Value(a.constant() / b.constant()) : program_of(a, b)->make(Program::Op::kDiv, a, b); }
Value operator-(Value a) { return a.is_constant() ? Value(-a.constant()) : a.program()->make(Program::Op::kNeg, a); }
Value sqrt(Value a) { return a.is_constant() ? Value(std::sqrt(a.constant())) : a.program()->make(Program::Op::kSqrt, a); }
Value sin(Value a) { return a.is_constant() ? Value(std::sin(a.constant())) : a.program()->make(Program::Op::kSin, a); }
Value cos(Value a) { return a.is_constant() ? Value(std::cos(a.constant())) : a.program()->make(Program::Op::kCos, a); }

Program::Program(std::string params, std::string spill) : params_(std::move(params)), spill_(std::move(spill)) {
  functions_.push_back({"", ""});
  function_nodes_.push_back(0);
  blocks_.push_back("");
}

Value Program::input(const std::string& expr) {
  const std::string k = "in:" + expr;
  if (auto it = index_.find(k); it != index_.end()) return Value(this, it->second);
  nodes_.push_back({Op::kInput, Value(), Value(), expr, static_cast<int>(functions_.size()) - 1,
                    static_cast<int>(blocks_.size()) - 1, mix(0, fnv1a(expr))});
  index_.emplace(k, static_cast<int>(nodes_.size()) - 1);
  return Value(this, static_cast<int>(nodes_.size()) - 1);
}

void Program::begin_function(const std::string& name, const std::string& doc) {
  functions_.push_back({name, doc});
  function_nodes_.push_back(0);
  base_name_ = name;
  base_doc_ = doc;
  parts_ = 1;
}

void Program::split_if_full() {
  if (function_nodes_.back() < max_statements || functions_.size() == 1) return;
  ++parts_;
  functions_.push_back({fmt::format("{}_{}", base_name_, parts_), base_doc_ + " (continued)"});
  function_nodes_.push_back(0);
}

void Program::begin_block(const std::string& name) { blocks_.push_back(name); }

void Program::comment(const std::string& text) {
  split_if_full();
  // Joint and cut names reach comments: made safe for a // line here, once.
  comments_.push_back({comment_text(text), static_cast<int>(functions_.size()) - 1, static_cast<int>(nodes_.size())});
}

// Functions are split only at comments and outputs (the emitters comment
// each body): the nodes created between two of them are the same set whatever
// order they were created in.
void Program::output(const std::string& target, Value value) {
  split_if_full();
  outputs_.push_back({target, value, false, static_cast<int>(functions_.size()) - 1, static_cast<int>(nodes_.size())});
}

void Program::accumulate(const std::string& target, Value value) {
  if (value.is(0.0)) return;
  split_if_full();
  outputs_.push_back({target, value, true, static_cast<int>(functions_.size()) - 1, static_cast<int>(nodes_.size())});
}

std::string Program::key(Op op, Value a, Value b) const {
  auto enc = [](Value v) {
    return v.is_constant() ? fmt::format("c{:x}", bits(v.constant())) : fmt::format("n{}", v.node());
  };
  return fmt::format("{}:{}:{}", static_cast<int>(op), enc(a), enc(b));
}

std::uint64_t Program::hash_of(Value v) const {
  return v.is_constant() ? mix(1, bits(v.constant())) : nodes_[static_cast<std::size_t>(v.node())].hash;
}

Value Program::make(Op op, Value a, Value b) {
  const auto neg_of = [&](Value v) -> const Value* {
    return !v.is_constant() && nodes_[v.node()].op == Op::kNeg ? &nodes_[v.node()].a : nullptr;
  };
  switch (fold_identities ? op : Op::kInput) {
    case Op::kAdd:
      if (a.is(0.0)) return b;
      if (b.is(0.0)) return a;
      if (const Value* nb = neg_of(b)) return make(Op::kSub, a, *nb);
      if (const Value* na = neg_of(a)) return make(Op::kSub, b, *na);
      break;
    case Op::kSub:
      if (b.is(0.0)) return a;
      if (a.is(0.0)) return make(Op::kNeg, b);
      if (!a.is_constant() && a.node() == b.node()) return Value(0.0);
      if (const Value* nb = neg_of(b)) return make(Op::kAdd, a, *nb);
      break;
    case Op::kMul:
      if (a.is(0.0) || b.is(0.0)) return Value(0.0);
      if (a.is(1.0)) return b;
      if (b.is(1.0)) return a;
      if (a.is(-1.0)) return make(Op::kNeg, b);
      if (b.is(-1.0)) return make(Op::kNeg, a);
      if (const Value* na = neg_of(a)) return make(Op::kNeg, make(Op::kMul, *na, b));
      if (const Value* nb = neg_of(b)) return make(Op::kNeg, make(Op::kMul, a, *nb));
      break;
    case Op::kDiv:
      if (b.is(1.0)) return a;
      if (a.is(0.0)) return Value(0.0);
      break;
    case Op::kNeg:
      if (a.is_constant()) return Value(-a.constant());
      if (const Value* na = neg_of(a)) return *na;
      break;
    default: break;
  }
  // Commutative operations: the node operand first, then the lower hash (the
  // node number only if two hashes collide), so a * b and b * a are one node
  // and its text does not depend on which was created first.
  const auto before = [&](Value x, Value y) {
    const std::uint64_t hx = hash_of(x), hy = hash_of(y);
    return hx < hy || (hx == hy && x.node() < y.node());
  };
  if ((op == Op::kAdd || op == Op::kMul) && !b.is_constant() && (a.is_constant() || before(b, a))) std::swap(a, b);
  if (functions_.size() == 1) throw std::logic_error("Program: begin_function() before the first operation");
  const std::string k = key(op, a, b);
  if (auto it = index_.find(k); it != index_.end()) return Value(this, it->second);
  nodes_.push_back({op, a, b, "", static_cast<int>(functions_.size()) - 1, static_cast<int>(blocks_.size()) - 1,
                    mix(mix(static_cast<std::uint64_t>(op) + 2, hash_of(a)), hash_of(b))});
  ++function_nodes_.back();
  index_.emplace(k, static_cast<int>(nodes_.size()) - 1);
  return Value(this, static_cast<int>(nodes_.size()) - 1);
}

std::vector<bool> Program::live() const {
  std::vector<bool> is_live(nodes_.size(), false);
  for (const Output& o : outputs_)
    if (!o.value.is_constant()) is_live[o.value.node()] = true;
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    if (!is_live[i]) continue;
    for (Value v : {nodes_[i].a, nodes_[i].b})
      if (!v.is_constant()) is_live[v.node()] = true;
  }
  return is_live;
}

// name[node]: the N of its tN (emit(): the order of its statement).
std::string Program::operand(Value v, const std::vector<int>& name) const {
  if (v.is_constant() && !std::isfinite(v.constant())) non_finite_ = true;
  if (v.is_constant()) return v.constant() < 0.0 ? fmt::format("({})", num(v.constant())) : num(v.constant());
  const Node& n = nodes_[v.node()];
  return n.op == Op::kInput ? n.text : fmt::format("t{}", name[static_cast<std::size_t>(v.node())]);
}

std::string Program::expression(const Node& n, const std::vector<int>& name) const {
  const auto a = [&] { return operand(n.a, name); };
  const auto b = [&] { return operand(n.b, name); };
  switch (n.op) {
    case Op::kAdd: return a() + " + " + b();
    case Op::kSub: return a() + " - " + b();
    case Op::kMul: return a() + " * " + b();
    case Op::kDiv: return a() + " / " + b();
    case Op::kNeg: return fmt::format("-{}", a());
    case Op::kSqrt: return "std::sqrt(" + a() + ")";
    case Op::kSin: return "std::sin(" + a() + ")";
    case Op::kCos: return "std::cos(" + a() + ")";
    case Op::kInput: return n.text;
  }
  return "";
}

namespace {

void count_op(Program::Op op, OpCount& c) {
  switch (op) {
    case Program::Op::kAdd:
    case Program::Op::kSub: ++c.add; break;
    case Program::Op::kMul: ++c.mul; break;
    case Program::Op::kDiv: ++c.div; break;
    case Program::Op::kSqrt: ++c.sqrt; break;
    case Program::Op::kSin:
    case Program::Op::kCos: ++c.trig; break;
    case Program::Op::kNeg:
    case Program::Op::kInput: break;
  }
}

}  // namespace

std::vector<double> Program::evaluate(const std::function<double(const std::string&)>& input) const {
  std::vector<double> x(nodes_.size());
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& n = nodes_[i];
    const double a = value(n.a, x), b = value(n.b, x);
    switch (n.op) {
      case Op::kInput: x[i] = input(n.text); break;
      case Op::kAdd: x[i] = a + b; break;
      case Op::kSub: x[i] = a - b; break;
      case Op::kMul: x[i] = a * b; break;
      case Op::kDiv: x[i] = a / b; break;
      case Op::kNeg: x[i] = -a; break;
      case Op::kSqrt: x[i] = std::sqrt(a); break;
      case Op::kSin: x[i] = std::sin(a); break;
      case Op::kCos: x[i] = std::cos(a); break;
    }
  }
  return x;
}

std::vector<std::pair<std::string, OpCount>> Program::count() const {
  const std::vector<bool> is_live = live();
  std::vector<std::pair<std::string, OpCount>> per_block;
  for (const std::string& b : blocks_) per_block.push_back({b, OpCount{}});
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (is_live[i]) count_op(nodes_[i].op, per_block[nodes_[i].block].second);
  per_block.erase(per_block.begin());  // the unnamed block before the first begin_block
  return per_block;
}

// The lines of emit() in order.  Statements in demand order: each output
// preceded by the nodes of its function it needs, depth first (operands left
// to right), so a value is computed next to its use.  Creation order (all
// kinematics, then all of M, ...) keeps thousands of values alive at once,
// which the compiler spills; in demand order the straight-line code needs
// fewer registers and fewer bytes of instructions (docs/specialization.md).
// Nothing here depends on the order the nodes were created in (program.hpp).
std::vector<Program::Event> Program::events(const std::vector<bool>& is_live) const {
  std::vector<Event> code;  // nodes and outputs
  std::vector<char> state(nodes_.size(), 0);  // 0 new, 1 operands pushed, 2 emitted
  auto demand = [&](int root, int function) {
    std::vector<int> stack{root};
    while (!stack.empty()) {
      const int i = stack.back();
      const Node& n = nodes_[static_cast<std::size_t>(i)];
      if (state[i] == 2 || n.op == Op::kInput || n.function != function) {
        stack.pop_back();
      } else if (state[i] == 0) {
        state[i] = 1;
        for (Value v : {n.b, n.a})
          if (!v.is_constant()) stack.push_back(v.node());
      } else {
        stack.pop_back();
        state[i] = 2;
        code.push_back({i, -1, -1});
      }
    }
  };
  for (std::size_t k = 0; k < outputs_.size(); ++k) {
    const Output& x = outputs_[k];
    if (!x.value.is_constant()) demand(x.value.node(), x.function);
    code.push_back({-1, static_cast<int>(k), -1});
  }
  // Values read only by later functions (through the spill array), by function and hash.
  std::vector<int> rest;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (is_live[i] && nodes_[i].op != Op::kInput && state[i] != 2) rest.push_back(static_cast<int>(i));
  std::sort(rest.begin(), rest.end(), [&](int i, int j) {
    const Node &a = nodes_[static_cast<std::size_t>(i)], &b = nodes_[static_cast<std::size_t>(j)];
    return a.function != b.function ? a.function < b.function : a.hash != b.hash ? a.hash < b.hash : i < j;
  });
  for (int i : rest) demand(i, nodes_[static_cast<std::size_t>(i)].function);

  // Comments: each before the first written statement among the nodes of its
  // function created after it and before the next comment or output (a set
  // that does not depend on the order of creation), else among all later ones.
  std::vector<int> position(nodes_.size(), -1);
  for (std::size_t e = 0; e < code.size(); ++e)
    if (code[e].node >= 0) position[code[e].node] = static_cast<int>(e);
  std::vector<int> marks;  // nodes_.size() at each comment and output
  for (const Comment& c : comments_) marks.push_back(c.after_node);
  for (const Output& o : outputs_) marks.push_back(o.after_node);
  std::sort(marks.begin(), marks.end());
  const auto earlier = [](int a, int b) { return a < 0 ? b : b < 0 ? a : std::min(a, b); };
  // later[i]: the first written of nodes i, i+1, ... of node i's function
  // (a function's nodes are consecutive).
  std::vector<int> later(nodes_.size() + 1, -1);
  for (std::size_t i = nodes_.size(); i-- > 0;)
    later[i] = earlier(position[i], i + 1 < nodes_.size() && nodes_[i + 1].function == nodes_[i].function ? later[i + 1] : -1);
  std::vector<std::vector<int>> comments_at(code.size() + 1);  // the last: trailing
  for (std::size_t c = 0; c < comments_.size(); ++c) {
    const Comment& m = comments_[c];
    const auto next = std::upper_bound(marks.begin(), marks.end(), m.after_node);
    const std::size_t end = next == marks.end() ? nodes_.size() : static_cast<std::size_t>(*next);
    int at = -1;
    for (std::size_t i = static_cast<std::size_t>(m.after_node); i < end; ++i)
      if (nodes_[i].function == m.function) at = earlier(at, position[i]);
    const std::size_t from = static_cast<std::size_t>(m.after_node);
    if (at < 0 && from < nodes_.size() && nodes_[from].function == m.function) at = later[from];
    comments_at[at < 0 ? code.size() : static_cast<std::size_t>(at)].push_back(static_cast<int>(c));
  }
  std::vector<Event> out;
  for (std::size_t e = 0; e <= code.size(); ++e) {
    for (int c : comments_at[e]) out.push_back({-1, -1, c});
    if (e < code.size()) out.push_back(code[e]);
  }
  return out;
}

Program::Emitted Program::emit(const std::string& prefix) const {
  non_finite_ = false;
  const std::vector<bool> is_live = live();
  // Live computed nodes read in a function other than their own: spilled.
  std::vector<char> spilled(nodes_.size(), 0);
  std::vector<std::vector<int>> imports(functions_.size());
  auto use = [&](Value v, int function) {
    if (v.is_constant() || nodes_[v.node()].op == Op::kInput) return;
    const int n = v.node();
    if (nodes_[n].function == function) return;
    spilled[n] = 1;
    auto& imp = imports[function];
    if (std::find(imp.begin(), imp.end(), n) == imp.end()) imp.push_back(n);
  };
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (is_live[i]) {
      use(nodes_[i].a, nodes_[i].function);
      use(nodes_[i].b, nodes_[i].function);
    }
  for (const Output& o : outputs_) use(o.value, o.function);

  const std::vector<Event> lines = events(is_live);
  // Names tN and spill slots in the order of the statements.
  Emitted out;
  std::vector<int> name(nodes_.size(), -1), slot(nodes_.size(), -1);
  int statements = 0;
  for (const Event& e : lines)
    if (e.node >= 0) {
      name[e.node] = statements++;
      if (spilled[e.node]) slot[e.node] = out.spills++;
    }
  std::vector<std::string> bodies(functions_.size());
  for (const Event& e : lines) {
    if (e.comment >= 0) {
      bodies[comments_[e.comment].function] += "  // " + comments_[e.comment].text + "\n";
    } else if (e.node >= 0) {
      const Node& n = nodes_[e.node];
      std::string& body = bodies[n.function];
      body += fmt::format("  const double t{} = {};\n", name[e.node], expression(n, name));
      if (slot[e.node] >= 0) body += fmt::format("  {}[{}] = t{};\n", spill_, slot[e.node], name[e.node]);
      ++out.statements;
      count_op(n.op, out.total);
    } else {
      const Output& x = outputs_[e.output];
      bodies[x.function] += fmt::format("  {} {} {};\n", x.target, x.accumulate ? "+=" : "=", operand(x.value, name));
      ++out.statements;
    }
  }

  const std::vector<std::string> params = parameter_names(params_);
  for (std::size_t f = 1; f < functions_.size(); ++f) {
    std::sort(imports[f].begin(), imports[f].end(), [&](int i, int j) { return name[i] < name[j]; });
    std::string head;
    for (int n : imports[f]) head += fmt::format("  const double t{} = {}[{}];\n", name[n], spill_, slot[n]);
    std::string body = head + bodies[f];
    // Strip comment-only bodies: a function with nothing to do is not emitted.
    if (body.find(';') == std::string::npos) continue;
    std::string voids, code;  // code: the body without its comment lines
    for (std::size_t at = 0; at < body.size();) {
      const std::size_t end = body.find('\n', at) + 1;
      if (body.compare(at, 4, "  //") != 0) code += body.substr(at, end - at);
      at = end;
    }
    for (const std::string& p : params)
      if (!uses_name(code, p)) voids += fmt::format("  (void){};\n", p);
    out.definitions += fmt::format("// {}\n{}void {}({}) {{\n{}{}}}\n\n", functions_[f].doc, prefix,
                                   functions_[f].name, params_, voids, body);
    out.calls.push_back(functions_[f].name);
  }
  out.block_ops = count();
  out.finite = !non_finite_;
  return out;
}

// ---- 3-vectors and 3x3 matrices ------------------------------------------------

Vec3 vec3(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

Mat3 mat3(const Eigen::Matrix3d& m) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[3 * i + j] = m(i, j);
  return r;
}

Mat3 identity3() { return mat3(Eigen::Matrix3d::Identity()); }

Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 operator*(Value s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
Value dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

Vec3 mul(const Mat3& R, const Vec3& x) {
  return {R[0] * x[0] + R[1] * x[1] + R[2] * x[2], R[3] * x[0] + R[4] * x[1] + R[5] * x[2],
          R[6] * x[0] + R[7] * x[1] + R[8] * x[2]};
}

Vec3 tmul(const Mat3& R, const Vec3& x) {
  return {R[0] * x[0] + R[3] * x[1] + R[6] * x[2], R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
          R[2] * x[0] + R[5] * x[1] + R[8] * x[2]};
}

Mat3 mul(const Mat3& A, const Mat3& B) {
  Mat3 C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
  return C;
}

Mat3 transpose(const Mat3& A) { return {A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8]}; }

}  // namespace jrgen::emit
