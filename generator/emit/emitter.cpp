// emit_solver(): the driver of the emit stage.  It asks the Plan what to
// write, calls one unit per generated block (generator/emit/README.md) and
// fills the templates' substitutions with their text.
#include "emit/emitter.hpp"
#include "emit/terms.hpp"

#include <fmt/format.h>

#include <string_view>

#include "emit/blocks.hpp"
#include "emit/dispatch.hpp"
#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/loops.hpp"
#include "emit/plan.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/steps.hpp"
#include "emit/template.hpp"
#include "ir/error.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

namespace {

// What the user asked for and did not get all of (jrgen: note: ...).
std::vector<std::string> notes(const Plan& plan, const Options& options, const LoopCode& loops) {
  std::vector<std::string> out;
  if (plan.parallel_declined && options.threads >= 2)
    out.push_back(fmt::format("--threads {}: the dof tree has no subtree to factor in parallel below its separator "
                              "(Corollary 3); Steps 1, 2 and 4 are serial",
                              options.threads));
  if (options.divide && !plan.unrolled)
    out.push_back("--divide: Steps 1, 2 and 4 run the runtime's loops (a model this large) and multiply by "
                  "reciprocal pivots");
  if (options.divide && !loops.reciprocal_steps.empty())
    out.push_back("--divide: Step " + loops.reciprocal_steps + " multiplies by reciprocal pivots");
  return out;
}

// Steps 1, 2 and 4 in the shape the plan chose (steps/*.cpp).
Steps124 steps124(const topology::Tree& t, const Plan& plan) {
  if (plan.unrolled) {
    const std::vector<std::vector<int>> desc = t.descendants();
    Steps124 s;
    s.step1 = step1_unrolled(t, plan, desc, s.ops1);
    s.step2 = step2_unrolled(t, plan, desc, s.ops2);
    s.step4 = step4_unrolled(t, plan, s.ops4);
    return s;
  }
  Steps124 s = runtime_loop_ops(t, plan);
  if (plan.shape == Shape::kSupernodal) supernodal_steps(t, plan, s);
  else if (plan.shape == Shape::kParallel) parallel_steps(t, plan, s);
  else table_steps(t, plan, s);
  return s;
}

// The values of the banner, shared by OUT.hpp and OUT.cpp.  Names from the
// user's files appear in // comments only, made safe there.
TemplateValues banner_values(const ir::Robot& robot, const topology::Tree& t, const Options& options) {
  TemplateValues v;
  v["version"] = JRGEN_VERSION;
  v["source"] = comment_text(options.source_name + (options.cuts_name.empty() ? "" : " + " + options.cuts_name));
  v["robot"] = comment_text(robot.name);
  v["ns"] = options.name_space;
  v["nv"] = std::to_string(t.nv);
  return v;
}

// OUT.hpp: the banner, the sizes, the API.
std::string header_text(const TemplateValues& banner, const topology::Tree& t, const Plan& plan) {
  TemplateValues v = banner;
  v["nq"] = std::to_string(t.nq);
  v["nc"] = std::to_string(t.nc());
  v["njoints"] = std::to_string(t.bodies.size());
  v["singular_api"] = singular_api(plan.proximal);
  return render_template("solver.hpp.tmpl", template_text("solver.hpp.tmpl"), v);
}

// The sizes and the summary of OUT.cpp's banner, and its runtime header.
void source_values(const topology::Tree& t, const Options& options, const Plan& plan, TemplateValues& v) {
  const int nc = t.nc();
  v["nb"] = std::to_string(t.bodies.size());
  v["nnz"] = std::to_string(t.nnz());
  v["nv_plus_1"] = std::to_string(t.nv + 1);
  v["header"] = options.header_name;
  v["method"] = plan.ldlt ? "L D L^T (no square roots)" : "L L^T (Cholesky)";
  if (nc == 0) {
    v["summary"] = fmt::format("tree, nq = {}, nv = {}, no constraints.", t.nq, t.nv);
  } else {
    int dropped = 0;
    for (const topology::Cut& c : t.cuts) dropped += c.rows - static_cast<int>(c.kept_rows.size());
    v["summary"] = fmt::format("closed loops, nq = {}, nv = {}, {} cut joint(s), nc = {} rows kept{}.", t.nq, t.nv,
                               t.cuts.size(), nc, dropped ? fmt::format(" ({} redundant dropped)", dropped) : "");
  }
  v["runtime_header"] =
      plan.shape == Shape::kSupernodal || plan.shape == Shape::kParallel ? "jrgen/factor.hpp" : "jrgen/runtime.hpp";
  // What Step 1 leaves in Dinv for check_digits_M (jr::pivot_spread): the
  // reciprocal pivots 1 / d (L D L^T) or 1 / l (L L^T), or with --divide in
  // straight-line code, where nothing else reads Dinv, the pivots d.
  v["m_pivots"] = plan.unrolled && !plan.write_dinv ? "false, 1" : plan.ldlt ? "true, 1" : "true, 2";
}

// The values the API templates (api_tree, api_loops) share.  With L D L^T
// the forward solve has a unit diagonal and needs no Dinv.
TemplateValues api_values(const Plan& plan) {
  TemplateValues api;
  api["step2_args"] = plan.ldlt ? "g_L, g_z" : "g_L, g_Dinv, g_z";
  return api;
}

std::string without_final_newline(std::string s) {
  if (!s.empty() && s.back() == '\n') s.pop_back();
  return s;
}

// The terms of forward_dynamics (its route, emit/terms.hpp) and the bodies
// of the API's pieces (mass_matrix, bias_forces, constraints, ...).
void terms_values(const topology::Tree& t, const Options& options, const Steps124& steps, const LoopCode& loops,
                  TemplateValues& api, TemplateValues& v, Solver& solver) {
  long long solve_flops = flops(steps.ops1) + flops(steps.ops2) + flops(steps.ops4);
  for (const StepOps& s : loops.ops) solve_flops += flops(s.ops);
  const TermsBlock terms = t.nc() == 0 ? tree_terms(t, options, solve_flops) : loop_terms(t, options, solve_flops);
  v["terms"] = terms.definitions.empty() ? "" : "\n" + terms.definitions + "\n";
  v["terms_include"] = terms.include;
  api["fd_body"] = terms.fd_body;
  if (t.nc() > 0) {
    const ConstraintPieces c = constraint_pieces(t);
    v["terms"] += c.definitions;
    api["constraints_body"] = without_final_newline(c.constraints_body);
    api["jacobian_body"] = without_final_newline(c.jacobian_body);
    api["gamma_body"] = without_final_newline(c.gamma_body);
  }
  const PieceTerms pieces = piece_terms(t, options);
  if (!pieces.definitions.empty()) v["terms"] += "\n" + pieces.definitions;
  v["mass_matrix_body"] = without_final_newline(pieces.mass_matrix_body);
  v["bias_forces_body"] = without_final_newline(pieces.bias_forces_body);
  v["route"] = terms.summary;
  solver.route = terms.summary;
  solver.terms_ops = terms.ops;
  solver.terms_unfolded_ops = terms.unfolded_ops;
  solver.fd_runs_steps = terms.route != TermsRoute::kArticulated && terms.route != TermsRoute::kRuntimeArticulated;
}

// Step 3 and the API: a tree gets no constraint code at all.
std::string constraint_values(const LoopCode& loops, const Plan& plan, int nc, TemplateValues api,
                              TemplateValues& v) {
  // The force elements' tables (model_tables) follow the cut joints'.
  v["constraint_tables"] = loops.tables + v["force_tables"];
  v.erase("force_tables");
  v["constraint_workspace"] = loops.workspace;
  v["step3"] = loops.step3;
  if (nc == 0) return render_template("api_tree.cpp.tmpl", template_text("api_tree.cpp.tmpl"), api);
  v["gather"] += "\n\n" + loops.gather;
  for (const auto& [key, value] : loops.call_args) api[key] = value;
  step34_api(plan.proximal, loops, nc, api);
  return render_template("api_loops.cpp.tmpl", template_text("api_loops.cpp.tmpl"), api);
}

// "JRGEN_STEP " before each definition of a step function: the lines of
// `code` that start (column 0) with "int step" or "void step".
std::string mark_step_definitions(const std::string& code) {
  const std::vector<std::string> lines = split_lines(code);
  std::string out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (i > 0) out += '\n';
    if (lines[i].rfind("int step", 0) == 0 || lines[i].rfind("void step", 0) == 0) out += "JRGEN_STEP ";
    out += lines[i];
  }
  return out;
}

// Steps as separate functions: inlined into one solve, the steps of a large
// model make one huge function that runs slower, most of all built
// position-independent as add_jr_solver() does (the HMMWV 4-14% slower
// inlined, with about the same number of instructions executed: how GCC
// schedules and lays out one huge function, not more work).  Small models
// keep the steps inlined, where the calls would cost more than they save
// (docs/benchmarks.md, run 7).  The same solvers keep the fences that
// Kernel::functions() wrote (kFenceProducts); the others lose them.
void separate_steps(const std::vector<StepOps>& ops, TemplateValues& v) {
  long long operations = 0;
  for (const StepOps& s : ops) operations += s.ops.add + s.ops.mul;
  v["step_attribute"] = "";
  if (operations < kMinOpsSeparateSteps) {
    // Small solvers keep their values in registers: no fences.
    for (const char* key : {"step1", "step2", "step3", "step4"}) v[key] = strip_fences(v[key]);
    return;
  }
  v["step_attribute"] =
      "// Each step below stays its own function (" + std::to_string(operations) +
      " additions and multiplications in all:\n"
      "// one function that large compiles to slower code), and the long steps\n"
      "// pass values from block to block through memory (jr::compiler_fence).\n"
      "// noclone: GCC would clone each step with the thread-local workspace\n"
      "// propagated into it, and then recompute the arrays' addresses after\n"
      "// fences, saving registers around each; as arguments they are plain pointers.\n"
      "// (target_clones copies a function, so a dispatched step cannot be noclone.)\n"
      "#if defined(__GNUC__) && !defined(__clang__) && !defined(JRGEN_DISPATCHED)\n"
      "#define JRGEN_STEP __attribute__((noinline, noclone))\n"
      "#elif defined(__GNUC__) || defined(__clang__)\n"
      "#define JRGEN_STEP __attribute__((noinline))\n"
      "#elif defined(_MSC_VER)\n"
      "#define JRGEN_STEP __declspec(noinline)\n"
      "#else\n"
      "#define JRGEN_STEP\n"
      "#endif\n\n";
  for (const char* key : {"step1", "step2", "step3", "step4"}) v[key] = mark_step_definitions(v[key]);
}

}  // namespace

Solver emit_solver(const ir::Robot& robot, const topology::Tree& t, const Options& options) {
  if (t.nv == 0)
    throw Error(ir::SourceLocation{robot.source_file, 0}, "robot", robot.name,
                "has no moving joints: there are no equations of motion to solve; give it at least one joint "
                "of type revolute, continuous, prismatic, planar, floating or ball");
  Plan plan = plan_solver(t, options);
  // Step 3 first: whether it is table-driven decides what Step 1 writes.
  LoopCode loops;
  if (t.nc() > 0) loops = emit_loops(t, options.method, options.divide, plan.unrolled, options.name_space);
  set_step3_shape(plan, loops.table_driven);
  const Steps124 steps = steps124(t, plan);

  Solver solver;
  solver.divide = options.divide;
  solver.notes = notes(plan, options, loops);
  TemplateValues v = banner_values(robot, t, options);
  solver.header = header_text(v, t, plan);

  singular_values(plan.proximal, v);
  source_values(t, options, plan, v);
  model_tables(t, options, v);
  v["step1"] = steps.step1 + (plan.fused ? "" : step1_gather_then_factor());
  v["step2"] = steps.step2;
  v["step4"] = steps.step4;
  v["gather"] = gathers(t, plan);
  TemplateValues api = api_values(plan);
  terms_values(t, options, steps, loops, api, v, solver);
  v["api"] = constraint_values(loops, plan, t.nc(), api, v);

  solver.ops = {{"1", steps.ops1}, {"2", steps.ops2}};
  solver.ops.insert(solver.ops.end(), loops.ops.begin(), loops.ops.end());
  solver.ops.push_back({"4", steps.ops4});
  separate_steps(solver.ops, v);
  v["dispatch"] = dispatch_macro();
  solver.source = mark_dispatch(render_template("solver.cpp.tmpl", template_text("solver.cpp.tmpl"), v));
  return solver;
}

}  // namespace jrgen::emit
