// The models every numeric test runs on: the project's own models, the real
// robots of ../shared/models-external (each given a floating base when the
// file has none), and seeded random trees of 1 to 500 bodies.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "ir/ir.hpp"

namespace jrgen::testing {

struct ModelCase {
  std::string name;  ///< short, usable as a test name
  std::string urdf;  ///< URDF text
  std::string cuts;  ///< --cuts file text, or empty
};

/// models/*.urdf that are trees (no <loop_joint>), read from JRGEN_SOURCE_DIR.
std::vector<ModelCase> project_tree_models();
/// Every ../shared/models-external/*.urdf, wrapped with add_floating_base().
std::vector<ModelCase> external_models();
/// Seeded random trees with mixed joint types, 1 to 500 bodies.
std::vector<ModelCase> random_trees();
/// All of the above.
std::vector<ModelCase> all_tree_models();

/// Closed-loop models: models/ with their cuts (hmmwv14, fourbar,
/// slider_crank, stewart), seeded random trees with random cut joints of
/// every type, and trains of 2 and 3 HMMWVs (loops_train_2, loops_train_3).
std::vector<ModelCase> loop_models();

/// Trees and loops.
std::vector<ModelCase> all_models();

/// Serial revolute chains of 1000 and 10 000 joints (issue 20: O(n) forward
/// dynamics), and a hanging rope of 300 joints tied back to its base
/// (loops_rope_300); in no list above, since a dense reference on the chains
/// is O(n^3) and the rope's only assembled state here is its singular one;
/// and a 300-joint chain with a gimbal in the middle, singular where its
/// middle joint is 0 (chain_gimbal_300), and a 40-joint one whose tip is tied
/// to the world by a distance cut (loops_gimbal_chain_40: loops with M singular
/// there).
std::vector<ModelCase> long_chains();

/// ../shared/models-external/icub.urdf as written (fixed base; as new users
/// try it), "fixed_icub": singular at its zero state (tests/generated/digits_test.cpp);
/// in no list above.
std::vector<ModelCase> fixed_base_robots();

/// The models of the extreme cases in time (tests/simulate/extreme/*.urdf:
/// mass ratios to 1e15, stiff springs, a near-toggle and a parallelogram
/// loop), "xt_<stem>" (trees) or "loops_xt_<stem>"; in no list above.
std::vector<ModelCase> extreme_in_time();

/// The case of all_models(), long_chains(), fixed_base_robots() or extreme_in_time() with this name; throws
/// std::runtime_error.
const ModelCase& find_model_case(const std::string& name);

/// The case's URDF and cuts through the URDF reader ("<name>.urdf" and
/// "<name>.cuts.xml" in messages).
ir::Robot read_model_case(const ModelCase& c);

/// Gives every link without mass a 10 g, 1e-6 kg m^2 <inertial>.
std::string give_massless_links_inertia(const std::string& urdf);
/// The URDF without its joints' <mimic> elements (tree dynamics of the external robots).
std::string without_mimic(const std::string& urdf);

/// For gtest parameter printing.
inline void PrintTo(const ModelCase& c, std::ostream* os) { *os << c.name; }

/// Reads a file into a string; throws std::runtime_error when unreadable.
std::string read_text(const std::string& path);

}  // namespace jrgen::testing
