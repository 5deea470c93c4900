// Step 3 of the algorithm of Section 4.3 (closed loops; internal to the emit
// stage): emit_loops() (emit/loops.hpp) writes Steps 3.1-3.5, the units here
// share this header.
#pragma once

#include <string>

#include "emit/loops.hpp"
#include "emit/template.hpp"

namespace jrgen::emit {

// --singular proximal (steps/proximal.cpp) -----------------------------------

/// The declaration of last_solve_regularized() for OUT.hpp ("" without).
std::string singular_api(bool proximal);
/// Template values singular_workspace and singular_definition of OUT.cpp.
void singular_values(bool proximal, TemplateValues& v);
/// Values proximal and step34_block of api_loops.cpp.tmpl: Step 3.4 of the
/// solve, regularized when T^T T fails its tests with `proximal`.
void step34_api(bool proximal, const LoopCode& loops, int m, TemplateValues& api);

}  // namespace jrgen::emit
