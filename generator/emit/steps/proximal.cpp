// --singular proximal (docs/singular.md): Step 3.4 for a singular or nearly
// singular T^T T by the proximal-point iteration, and the API around it
// (last_solve_regularized()).  Off: the generated solve returns status 2.
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"

namespace jrgen::emit {

namespace {

// --singular proximal: Step 3.4 for a singular or nearly singular T^T T,
// by the proximal-point iteration (iterated Tikhonov).  Runs only after the
// regular factor failed its tests; the regular path is unchanged.
std::string proximal_step34(const LoopCode& loops, int m) {
  return fmt::format(R"(
// ---- Step 3.4, regularized (--singular proximal; docs/singular.md) ----------
// Runs when T^T T is singular or nearly so (a pivot of its factor, or the
// pivots' spread, failed its test): lambda by the proximal-point iteration
// (iterated Tikhonov regularization) on W = T^T T,
//     (W + mu I) lambda_(k+1) = z_m + mu lambda_k,   lambda_0 = 0,
// mu = sqrt(eps) max_j W_jj, kProximalIterations steps.  Every iterate stays
// in range(W) (z_m = T^T z_n - gamma is there when the system is consistent,
// as at an assembled state with Phiq v = 0 along the singular rows), and an
// eigencomponent of W with eigenvalue s converges to its share of the
// minimum-norm lambda = W^+ z_m by the factor mu / (s + mu) per step: below
// 1.5e-4 for s >= 1e-4 max W_jj, so 5 steps leave (1.5e-4)^5 ~ 1e-19 of it.
// The null space of W is that of T and of Phiq^T: it adds nothing to
// Phiq^T lambda, so qdd (Steps 3.5, 4) is the unique solution of eq. (17).
// Rounding puts ~eps |z_m| into the null space each step, which leaves
// ~5 sqrt(eps) |z_m| / max W_jj (~1e-7 relative) of it in lambda and nothing
// measurable in Phiq^T lambda.  Components with 0 < s < mu (a state within
// ~1e-8 of the singular one, relative) are damped: their constraint
// direction is relaxed: proximal_digits (below) then returns status 2.  Cost:
// kProximalIterations times Steps 3.3 and 3.4
// (W is formed and factored afresh each step), on singular states only.
constexpr int kProximalIterations = 5;
constexpr double kProximalShift = 1.4901161193847656e-08;  // sqrt(eps)
constexpr double kProximalDigits = 1e-6;  // status 0: qdd to 6 digits (docs/singular.md)
// Position of each diagonal entry of W in g_W (elimination order).
constexpr std::int32_t kWDiag[{0}] = {{ {1} }};
thread_local double g_zm0[{0}];     // z_m of Step 3.2, kept for the iteration
thread_local double g_lambda[{0}];  // lambda_k
thread_local double g_dlambda[{0}];       // Delta_k = lambda_k - lambda_(k-1), for proximal_digits
thread_local double g_dlambda_prev[{0}];  // Delta_(k-1)
constexpr double kProximalEps = 2.220446049250313e-16;

// Has the regularized qdd its digits?  Status 0 only if the part of qdd the iteration has
// not reached is below 1e-6 of the constraint forces' share of qdd, |M^-1 Phiq^T lambda|_M
// (docs/singular.md, "Status 0 of the regularized solve").  The eigencomponents of W =
// Phiq M^-1 Phiq^T act on qdd along M-orthogonal directions, |M^-1 Phiq^T x|_M^2 = x^T W x.
// The last step moved the component of eigenvalue s by Delta_s = (mu / (s + mu))^(k-1)
// s / (s + mu) z_s / s; what it still lacks is Delta_s mu / s.  Eigenvalues below
// nc eps max W_jj are rounding (the exactly singular directions, where eq. (17) leaves
// lambda free and qdd unchanged); above them mu / s <= 1 / (nc sqrt(eps)), so
// |qdd missing|_M <= sqrt(Delta^T W Delta) / (nc sqrt(eps)).  From the iteration,
// W lambda_k = z_m - mu Delta_k, so W Delta_k = mu (Delta_(k-1) - Delta_k) and
// lambda^T W lambda = lambda^T (z_m - mu Delta_k): both without W (whose storage differs
// between the variants of Step 3).  Near, not at, a singular configuration (0 < s < mu:
// a constraint force the regularization drops) the bound is large: status 2, naming the row
// whose multiplier moved most in the last step.
int proximal_digits(double mu) {{
  double dd = 0.0, dp = 0.0, lw = 0.0;
  for (std::int32_t r = 0; r < nc; ++r) {{
    dd += g_dlambda[r] * g_dlambda[r];
    dp += g_dlambda[r] * g_dlambda_prev[r];
    lw += g_lambda[r] * (g_zm0[r] - mu * g_dlambda[r]);
  }}
  // Delta^T W Delta, plus the rounding of its difference of two sums.
  const double dwd = mu * (std::fabs(dp - dd) + 4.0 * kProximalEps * std::sqrt(dd) * std::sqrt(std::fmax(dd, std::fabs(dp))));
  const double missing = std::sqrt(dwd) / (nc * kProximalShift);
  const double scale = std::sqrt(std::fabs(lw));
  if (!(missing > kProximalDigits * scale)) return kSuccess;
  std::int32_t row = 0;
  for (std::int32_t r = 1; r < nc; ++r)
    if (std::fabs(g_dlambda[r]) > std::fabs(g_dlambda[row])) row = r;
  return fail_row(kConstraintsSingular,
                  // value: the bound on the relative error of qdd; at most 100 characters
                  "regularized solve without its digits: near, not at, a singular configuration",
                  row, missing / scale);
}}

// lambda into g_zm (user row order); status 2 (and no answer) if W + mu I fails too.
// g_digits_status: proximal_digits' verdict, returned by solve_closed once qdd and lambda
// are written (status 2 then comes with the regularized answer, last_solve_regularized()).
thread_local int g_digits_status = kSuccess;
int proximal_lambda() {{
  for (std::int32_t r = 0; r < nc; ++r) {{
    g_zm0[r] = g_zm[r];
    g_lambda[r] = 0.0;
    g_dlambda[r] = 0.0;
  }}
  double mu = 0.0;
  for (int k = 0; k < kProximalIterations; ++k) {{
    step33_TtT({2});  // W afresh: Step 3.4 factored it in place
    if (k == 0) {{
      for (std::int32_t j = 0; j < nc; ++j) mu = std::fmax(mu, g_W[kWDiag[j]]);
      mu *= kProximalShift;
    }}
    for (std::int32_t j = 0; j < nc; ++j) g_W[kWDiag[j]] += mu;
    for (std::int32_t r = 0; r < nc; ++r) g_zm[r] = g_zm0[r] + mu * g_lambda[r];
    if (const int status = step34_factor(g_W, g_Winv)) {{
      g_regularized = false;  // no regularized answer either
      return status;
    }}
    step34_solve(g_W, g_Winv, g_zm);
    for (std::int32_t r = 0; r < nc; ++r) {{
      g_dlambda_prev[r] = g_dlambda[r];
      g_dlambda[r] = g_zm[r] - g_lambda[r];
      g_lambda[r] = g_zm[r];
    }}
  }}
  g_digits_status = proximal_digits(mu);
  return kSuccess;
}}
)",
                     m, join_ints(loops.W_diag), loops.call_args.at("step33_args"));
}

}  // namespace

std::string singular_api(bool proximal) {
  if (!proximal) return "";
  return "// Generated with --singular proximal (docs/singular.md): after a solve in this\n"
         "// thread, true when T^T T was singular or nearly so and lambda came from the\n"
         "// regularized Step 3.4 (the minimum-norm lambda of a consistent system; qdd and\n"
         "// Phiq^T lambda are then still unique), false when the regular solve ran.  With\n"
         "// status 0 the answer has its digits; with status 2 and true, qdd and lambda hold\n"
         "// the regularized answer of a state near, not at, the singular configuration,\n"
         "// without its digits (last_error() gives the bound).  Always false for a tree.\n"
         "bool last_solve_regularized();\n\n";
}

void singular_values(bool proximal, TemplateValues& v) {
  v["singular_workspace"] =
      proximal ? "\nthread_local bool g_regularized = false;  // --singular proximal: last_solve_regularized()" : "";
  v["singular_definition"] = proximal ? "\nbool last_solve_regularized() { return g_regularized; }\n" : "";
}

void step34_api(bool proximal, const LoopCode& loops, int m, TemplateValues& api) {
  api["proximal"] = proximal ? proximal_step34(loops, m) : "";
  api["proximal_return"] =
      proximal ? "  // --singular proximal: the regularized answer is written; without its digits, status 2.\n"
                 "  if (g_regularized && g_digits_status != kSuccess) return g_digits_status;\n"
               : "";
  api["step34_block"] =
      proximal ? "  // Step 3.4: factor, or (T^T T singular or nearly so) the regularized solve.\n"
                 "  g_regularized = step34_factor(g_W, g_Winv) != kSuccess || check_digits_W(g_Winv) != kSuccess;\n"
                 "  if (!g_regularized) {\n"
                 "    step34_solve(g_W, g_Winv, g_zm);\n"
                 "  } else if (const int status = proximal_lambda()) {\n"
                 "    return status;\n"
                 "  }"
               : "  if (const int status = step34_factor(g_W, g_Winv)) return status;\n"
                 "  if (const int status = check_digits_W(g_Winv)) return status;\n"
                 "  step34_solve(g_W, g_Winv, g_zm);";
}

}  // namespace jrgen::emit
