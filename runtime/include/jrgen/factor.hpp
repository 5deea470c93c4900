// Steps 1, 2 and 4 of Section 4.3 in two further shapes, chosen by the
// generator for large models (the runtime knows nothing of the generator):
//
//  * Supernodal (dense parts).  A supernode is a maximal run of dofs
//    first, first+1, ..., last of the Lemma 2 dof tree where every dof but the
//    first is the parent of the one before it and has no other child.  Their
//    columns of L then share one structure (eq. 18 with Lemma 2): the dense
//    lower triangle of rows first..last plus a dense panel of the common
//    ancestor rows (the ancestors of last).  Such a block is factored with
//    Eigen's blocked Cholesky, its panel by a triangular solve, and the
//    rank-s update of the panel is subtracted from the ancestors' columns;
//    Steps 2 and 4 use dense triangular solves and matrix-vector products.
//    Every other column goes through the scalar loops of factor_packed().
//
//  * Subtree kernels (Corollary 3 of Section 5).  Columns of L in disjoint
//    subtrees depend on nothing outside them, so the generator's parallel
//    variant factors and substitutes each subtree as a task; their updates
//    of the rows above a subtree (the separator) go to a private buffer that
//    is added in afterwards, serially, before the separator is processed.
#pragma once

#include <cstdint>

#include "jrgen/runtime.hpp"

namespace jr {

/// One dense supernode: dofs [first, first + size), rows = size + number of
/// ancestors of the last dof.  Its columns of L are stored column-major in a
/// dense buffer at `offset`, leading dimension `rows`: row r < size is dof
/// first + r, row size + u is the u-th ancestor of the last dof (nearest first),
/// i.e. the order of the packed column `first`.
struct Supernode {
  std::int32_t first;
  std::int32_t size;
  std::int32_t rows;
  std::int64_t offset;
};

/// L L^T of the packed M (in place; a supernode's columns end up in `S`
/// instead).  `nodes` lists the dense supernodes in increasing `first`.
/// Returns -1, or the Lemma 2 dof whose pivot was <= pivot_tolerance * M[j, j]
/// (or NaN), its pivot in *pivot, exactly as factor_packed().
std::int32_t factor_supernodal(const Model& model, const Supernode* nodes, std::int32_t num_nodes, double* L,
                               double* S, double* Dinv, double pivot_tolerance, double* pivot);

/// Step 2 (L z = Q) and Step 4 (L^T x = z) in place after factor_supernodal().
void forward_supernodal(const Model& model, const Supernode* nodes, std::int32_t num_nodes, const double* L,
                        const double* S, const double* Dinv, double* z);
void backward_supernodal(const Model& model, const Supernode* nodes, std::int32_t num_nodes, const double* L,
                         const double* S, const double* Dinv, double* z);

/// A complete subtree of the dof tree: dofs [first, root] (Lemma 2 post-order
/// keeps a subtree contiguous, root last).  Its `path` ancestors (the
/// separator dofs above root) receive its updates through a private buffer of
/// path * path doubles at `buffer` (Step 1) and `path` doubles (Step 2).
struct Subtree {
  std::int32_t first;
  std::int32_t root;
  std::int32_t path;
  std::int64_t buffer;
};

/// Dinv[j] = M[j, j] for every dof (the reference of the relative pivot test).
void save_diagonal(const Model& model, const double* L, double* Dinv);

/// Step 1 on one subtree (after save_diagonal()): columns first..root as
/// factor_packed(); updates of the rows above root are accumulated into
/// U (path x path, column-major, zeroed here).  Returns -1 or the failing dof.
std::int32_t factor_subtree(const Model& model, const Subtree& t, double* L, double* Dinv, bool ldlt,
                            double pivot_tolerance, double* pivot, double* U);

/// Subtracts a subtree's buffer U from the packed columns of its path.
void apply_subtree_update(const Model& model, const Subtree& t, const double* U, double* L);

/// Step 1 on every dof outside the subtrees (serially, after their updates
/// were applied), as factor_packed().
std::int32_t factor_separator(const Model& model, const Subtree* trees, std::int32_t num_trees, double* L,
                              double* Dinv, bool ldlt, double pivot_tolerance, double* pivot);

/// Step 2 on one subtree; the updates of the path rows go to u (path, zeroed here).
void forward_subtree(const Model& model, const Subtree& t, const double* L, const double* Dinv, bool ldlt,
                     double* z, double* u);
/// z[path dof k] -= u[k].
void apply_subtree_forward(const Model& model, const Subtree& t, const double* u, double* z);
/// Step 2 on the separator, after every subtree's update was applied.
void forward_separator(const Model& model, const Subtree* trees, std::int32_t num_trees, const double* L,
                       const double* Dinv, bool ldlt, double* z);
/// Step 4: the separator first (serially), then each subtree (independently).
void backward_separator(const Model& model, const Subtree* trees, std::int32_t num_trees, const double* L,
                        const double* Dinv, bool ldlt, double* z);
void backward_subtree(const Model& model, const Subtree& t, const double* L, const double* Dinv, bool ldlt,
                      double* z);

}  // namespace jr
