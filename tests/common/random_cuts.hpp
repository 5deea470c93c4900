// Seeded random cut joints for random trees: every cut closes exactly at the
// zero configuration, because both of its frames are one world frame
// expressed in the two links' frames there.
#pragma once

#include <cstdint>
#include <string>

namespace jrgen::testing {

struct RandomCutOptions {
  std::uint64_t seed = 1;
  int num_cuts = 3;  ///< cut types cycle through all seven, starting at seed % 7
};

/// A --cuts file (<loop_joints>) for the URDF text; links are chosen among
/// those moved by a joint, k and l on different moving joints.
std::string random_cuts_xml(const std::string& urdf_text, const RandomCutOptions& options);

}  // namespace jrgen::testing
