#include "peers_core.hpp"

#include <benchmark/benchmark.h>

#include <Eigen/QR>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>

#include "fd_reference.hpp"
#include "mujoco_urdf.hpp"
#include "reference/reference_dynamics.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen::peers {

namespace {

const Eigen::Vector3d kGravity(0, 0, -9.81);  // jrgen's default --gravity, MuJoCo's default

JointLayout layout_of(const GeneratedApi& g) {
  JointLayout l;
  for (int j = 0; j < g.njoints; ++j) {
    l.names.emplace_back(g.joint_names[j]);
    l.q0.push_back(g.joint_q_index[j]);
    l.v0.push_back(g.joint_v_index[j]);
    l.nq.push_back((j + 1 < g.njoints ? g.joint_q_index[j + 1] : g.nq) - g.joint_q_index[j]);
    l.nv.push_back((j + 1 < g.njoints ? g.joint_v_index[j + 1] : g.nv) - g.joint_v_index[j]);
  }
  return l;
}

// Trees: a random configuration (angles in [-1, 1], random unit quaternions),
// v in [-1, 1], tau in [-10, 10].  Closed loops: a small step from the
// assembled zero configuration, Newton-projected with the solver's own
// constraints until |Phi|_inf < 1e-12, v projected onto Phiq v = 0.
State make_state(const ir::Robot& robot, const GeneratedApi& g, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s;
  s.q = g.nc == 0 ? reference::random_configuration(robot, rng) : reference::neutral_configuration(robot);
  s.v = reference::random_velocity(robot, rng);
  s.tau = Eigen::VectorXd::NullaryExpr(g.nv, [&] { return 10.0 * u(rng); });
  if (g.nc == 0) return s;
  s.q = reference::integrate(robot, s.q, Eigen::VectorXd::NullaryExpr(g.nv, [&] { return 0.03 * u(rng); }), 1.0);
  Eigen::VectorXd phi(g.nc);
  Eigen::MatrixXd J(g.nc, g.nv);
  for (int it = 0; it < 60; ++it) {
    g.constraints(s.q.data(), phi.data());
    if (phi.cwiseAbs().maxCoeff() < 1e-12) break;
    g.constraint_jacobian(s.q.data(), J.data());
    s.q = reference::integrate(robot, s.q, -J.completeOrthogonalDecomposition().solve(phi), 1.0);
  }
  g.constraint_jacobian(s.q.data(), J.data());
  for (int pass = 0; pass < 2; ++pass) s.v -= J.transpose() * (J * J.transpose()).ldlt().solve(J * s.v);
  return s;
}

// The generated calls.  Buffers live as long as the cases (shared_ptr).
struct JrBuffers {
  Eigen::MatrixXd M, Phiq;
  Eigen::VectorXd h, Q, gamma, qdd, lambda;
};

void add_jrgen_cases(const GeneratedApi& g, const State& s, std::vector<Case>& cases) {
  auto b = std::make_shared<JrBuffers>();
  const int n = g.nv, m = g.nc;
  b->M.setZero(n, n);
  b->Phiq.setZero(m, n);
  b->h.setZero(n);
  b->gamma.setZero(m);
  b->qdd.setZero(n);
  b->lambda.setZero(m);
  double* lambda = m ? b->lambda.data() : nullptr;
  auto qdd = [b](Eigen::VectorXd& out) { out = b->qdd; };
  cases.push_back({"jrgen/forward_dynamics",
                   [&g, &s, b, lambda] {
                     if (g.forward_dynamics(s.q.data(), s.v.data(), s.tau.data(), b->qdd.data(), lambda))
                       std::abort();
                   },
                   qdd});
  cases.push_back({"jrgen/mass_matrix", [&g, &s, b] { g.mass_matrix(s.q.data(), b->M.data()); }, {}});
  cases.push_back({"jrgen/bias_forces", [&g, &s, b] { g.bias_forces(s.q.data(), s.v.data(), b->h.data()); }, {}});
  if (m > 0)
    cases.push_back({"jrgen/constraint_jacobian+gamma",
                     [&g, &s, b] {
                       g.constraint_jacobian(s.q.data(), b->Phiq.data());
                       g.constraint_gamma(s.q.data(), s.v.data(), b->gamma.data());
                     },
                     {}});
  // solve_augmented reads only its inputs: computed once here.
  g.mass_matrix(s.q.data(), b->M.data());
  g.bias_forces(s.q.data(), s.v.data(), b->h.data());
  b->Q = s.tau - b->h;
  if (m > 0) {
    g.constraint_jacobian(s.q.data(), b->Phiq.data());
    g.constraint_gamma(s.q.data(), s.v.data(), b->gamma.data());
  }
  cases.push_back({"jrgen/solve_augmented",
                   [&g, b, m, lambda] {
                     if (g.solve_augmented(b->M.data(), b->Q.data(), m ? b->Phiq.data() : nullptr,
                                           m ? b->gamma.data() : nullptr, b->qdd.data(), lambda))
                       std::abort();
                   },
                   qdd});
}

// MuJoCo's case, or the reason it is left out.
std::string add_mujoco_case(const ModelInfo& info, const ir::Robot& robot, const GeneratedApi& g, const State& s,
                            std::vector<Case>& cases) {
  const std::string why = mujoco_unsupported(robot);
  if (!why.empty()) return why;
  // JRGEN_PEERS_MJ_COMPILER: more compiler attributes, for experiments
  // (e.g. fusestatic=false; a later attribute replaces an earlier one).
  std::string compiler = info.mj_compiler;
  if (const char* extra = std::getenv("JRGEN_PEERS_MJ_COMPILER")) compiler += std::string(" ") + extra;
  auto mj = std::make_shared<MujocoForward>(info.urdf, compiler, info.mj_urdf, layout_of(g));
  if (!mj->ok()) return mj->error();
  mj->set_state(s.q.data(), s.v.data(), s.tau.data());
  const int n = g.nv;
  cases.push_back({"mujoco/mj_forward", [mj] { mj->forward(); },
                   [mj, n](Eigen::VectorXd& out) {
                     out.resize(n);
                     mj->qdd(out.data());
                   }});
  return mj->passive() ? "passive forces on (damping)" : "passive forces off (no damping)";
}

struct Accuracy {
  double err_ref = -1, err_jrgen = -1;
};

std::vector<char*> benchmark_args(int argc, char** argv, bool& quick, std::vector<std::string>& store) {
  std::vector<char*> rest = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--quick")
      quick = true;
    else
      rest.push_back(argv[i]);
  }
  // The median of repetitions whose order is shuffled across all calls, so
  // that a change of the machine's speed falls on every call alike.
  store = {quick ? "--benchmark_min_time=0.01" : "--benchmark_min_time=0.2",
           quick ? "--benchmark_repetitions=3" : "--benchmark_repetitions=15",
           "--benchmark_enable_random_interleaving=true", "--benchmark_report_aggregates_only=true"};
  std::vector<char*> out = {argv[0]};
  for (std::string& a : store) out.push_back(a.data());
  out.insert(out.end(), rest.begin() + 1, rest.end());
  return out;
}

}  // namespace

int run(int argc, char** argv, const ModelInfo& info, const GeneratedApi& g) {
  bool quick = false;
  std::vector<std::string> store;
  std::vector<char*> args = benchmark_args(argc, argv, quick, store);
  int gb_argc = static_cast<int>(args.size());
  benchmark::Initialize(&gb_argc, args.data());
  if (benchmark::ReportUnrecognizedArguments(gb_argc, args.data())) return 2;

  ir::Robot robot = urdf::read_robot(info.urdf);
  if (info.cuts[0]) urdf::read_cuts(info.cuts, robot);
  const State s = make_state(robot, g, 20261204);
  const Eigen::VectorXd ref = report::reference_qdd(robot, s.q, s.v, s.tau, kGravity);

  std::vector<Case> cases;
  add_jrgen_cases(g, s, cases);
  const std::string mj_note = add_mujoco_case(info, robot, g, s, cases);
  benchmark::AddCustomContext("mujoco", mj_note);
  const bool floating = !robot.joints.empty() && robot.joints[0].type == ir::JointType::Floating;
  benchmark::AddCustomContext("base", floating ? "floating" : "fixed");
#ifdef JRGEN_PEERS_PINOCCHIO
  std::string pin_note = mujoco_unsupported(robot);
  if (pin_note.empty()) {
    Eigen::VectorXd damping(g.nv);
    int at = 0;
    for (const ir::Joint& j : robot.joints)
      for (int k = 0; k < ir::joint_nv(j.type); ++k) damping[at++] = j.damping;
    pin_note = pinocchio_cases(info.urdf, layout_of(g), damping, s, cases);
  }
  std::fprintf(stderr, "%-10s pinocchio: %s\n", info.name, pin_note.c_str());
  benchmark::AddCustomContext("pinocchio", pin_note);
#endif
  benchmark::AddCustomContext("model", info.name);
  benchmark::AddCustomContext("nv_nc", std::to_string(g.nv) + " " + std::to_string(g.nc));

  // Accuracy: one call each, before any timing; jrgen's forward_dynamics first.
  std::vector<Accuracy> acc(cases.size());
  Eigen::VectorXd jr_qdd, x;
  cases[0].run();
  cases[0].qdd(jr_qdd);
  bool ok = true;
  for (std::size_t c = 0; c < cases.size(); ++c) {
    if (!cases[c].qdd) continue;
    cases[c].run();
    cases[c].qdd(x);
    acc[c] = {report::relative_error(x, ref), report::relative_error(x, jr_qdd)};
    std::fprintf(stderr, "%-10s %-34s err vs reference %.2e   vs jrgen %.2e\n", info.name, cases[c].name.c_str(),
                 acc[c].err_ref, acc[c].err_jrgen);
    // Catches a wrong mapping or formula (an O(1) error), not rounding: the
    // accuracy tests bound the rounding (tests/generated).
    if (cases[c].name.rfind("jrgen/", 0) == 0 && !(acc[c].err_ref < 1e-6)) ok = false;
  }
  std::fprintf(stderr, "%-10s mujoco: %s\n", info.name, mj_note.c_str());

  for (std::size_t c = 0; c < cases.size(); ++c) {
    const Case* cp = &cases[c];
    const Accuracy a = acc[c];
    benchmark::RegisterBenchmark(cp->name.c_str(), [cp, a, &g](benchmark::State& state) {
      for (auto _ : state) {
        cp->run();
        benchmark::ClobberMemory();
      }
      state.counters["nv"] = g.nv;
      state.counters["nc"] = g.nc;
      state.counters["err_ref"] = a.err_ref;
      state.counters["err_jrgen"] = a.err_jrgen;
    })->Unit(benchmark::kMicrosecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!ok) std::fprintf(stderr, "peers: %s: jrgen's qdd is far from the reference\n", info.name);
  return ok ? 0 : 1;
}

}  // namespace jrgen::peers
