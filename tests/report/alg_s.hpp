// Alg-S, interpreted: the algorithm of Section 4.3 exactly as the generated
// code runs it (Lemma 2 order, packed L, the Lemma 3 blocks of T, Step 3.3 only
// over pairs of cuts whose paths overlap, a dense Cholesky factorization of
// T^T T), but driven at run time by topology tables through loops.  Measuring
// it beside the generated solver isolates what loop-free generation buys.
//
// Steps 1, 2 and 4 use the runtime's table-driven routines
// (jr::factor_packed / forward_packed / backward_packed); Step 3 is written
// here.  Every step reads its input from a separate array, so each step can be
// timed alone (Table 5) and the whole solve can be repeated.
#pragma once

#include <jrgen/runtime.hpp>

#include <cstdint>
#include <memory>
#include <vector>

#include "analysis/runtime_model.hpp"
#include "topology/topology.hpp"

namespace jrgen::report {

class AlgS {
 public:
  /// Tables from the tree (cuts' kept_rows already chosen).  The dense inputs
  /// are user order, column-major: M (nv x nv), Phiq (nc x nv).
  AlgS(const topology::Tree& tree, const double* M, const double* Q, const double* Phiq, const double* gamma);

  // The steps of Section 4.3 (Step 0, y_n = 0, is implicit).
  int step1();     ///< gather M into the packed layout; L L^T = M (eq. 18 pattern, no fill-in)
  void step2();    ///< z_n = L^-1 Q
  void step3_1();  ///< T = L^-1 Phiq^T, column per constraint row, Lemma 3 rows only
  void step3_2();  ///< z_m = T^T z_n - gamma
  void step3_3();  ///< W = T^T T, only blocks of cut pairs with overlapping paths
  int step3_4();   ///< W = G G^T (dense Cholesky), lambda = W^-1 z_m
  void step3_5();  ///< y_n = z_n - T lambda
  void step4();    ///< qdd = L^-T y_n, scattered to user order
  /// All steps in order; 0 on success, a jr::Status otherwise.
  int solve();
  /// Runs step k (0: 1, 1: 2, 2..6: 3.1..3.5, 7: 4).
  void run_step(int k);

  const std::vector<double>& qdd() const { return qdd_; }
  const std::vector<double>& lambda() const { return lambda_; }

 private:
  struct CutBlock {
    std::vector<std::int32_t> dofs;  ///< Lemma 3 rows of T for this cut (Lemma 2 order, ascending)
    std::int32_t first_row = 0, rows = 0;  ///< kept rows of the cut in Phiq / lambda
    std::int32_t T_start = 0;              ///< T stores rows x dofs.size() entries from here
  };
  /// Two cuts whose paths to the base share dofs: positions of the shared
  /// dofs in each cut's list (Step 3.3 sums over exactly these).
  struct Overlap {
    std::int32_t a, b;
    std::vector<std::int32_t> pos_a, pos_b;
  };

  const double *M_, *Q_, *Phiq_, *gamma_;
  std::unique_ptr<analysis::RuntimeModel> rt_;
  const jr::Model* model_;
  int nv_, nc_;
  std::vector<std::int32_t> M_src_;  ///< packed entry -> index into the dense user M
  std::vector<std::int32_t> dof_user_;
  std::vector<std::int32_t> entry_row_, row_start_, row_entry_, row_col_;  ///< jr::PackedRows
  jr::PackedRows rows_{};
  std::vector<CutBlock> cuts_;
  std::vector<Overlap> overlaps_;
  std::vector<std::int32_t> T_src_;  ///< T entry -> index into the dense user Phiq
  std::vector<double> L_, Dinv_, z_, T_, zm_, W_, G_, lambda_, y_, x_, w_, qdd_;
};

}  // namespace jrgen::report
