// Pictures of a mechanism (docs/interface.md section 1, --graph; issue 22):
//   - the topology graph as Graphviz DOT: bodies with the links fused into
//     them, tree joints with their types, cut joints drawn apart (dashed), and
//     the Lemma 2 numbering, as in the paper's Figures 3 and 4;
//   - the structural patterns of the factor L (Lemma 2: no fill-in), of
//     T = L^-1 Phiq^T (Lemma 3) and of T^T T (Remark 4) as one SVG picture.
#pragma once

#include <string>

#include "ir/ir.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// The topology graph, Graphviz DOT text (deterministic).
std::string topology_dot(const ir::Robot& robot, const topology::Tree& tree);

/// The patterns of L (nv x nv), T (nv x nc kept rows) and T^T T (nc x nc),
/// rows and columns in Lemma 2 order, as a standalone SVG (deterministic).
std::string sparsity_svg(const ir::Robot& robot, const topology::Tree& tree);

/// Renders DOT text to SVG with Graphviz's `dot` found on PATH; throws
/// jrgen::Error naming `for_path` and the fix when dot is missing or fails.
std::string render_svg(const std::string& dot_text, const std::string& for_path);

}  // namespace jrgen::emit
