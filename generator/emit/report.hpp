// --report OPS.md: operation counts of the emitted code, per step of
// Section 4.3, shaped like the paper's Tables 1-3.
#pragma once

#include <string>

#include "emit/emitter.hpp"

namespace jrgen::emit {

std::string operation_report(const ir::Robot& robot, const topology::Tree& tree, const Solver& solver);

}  // namespace jrgen::emit
