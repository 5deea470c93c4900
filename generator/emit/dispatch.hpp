// Processor dispatch of the generated code (docs/specialization.md,
// "Processor dispatch").
//
// Built without -march, a C++ compiler for x86-64 may use only SSE2: two-operand
// instructions (a register copy before most operations of straight-line code)
// and no fused multiply-add.  The generated routines are therefore compiled
// twice, for the baseline and for x86-64-v3 (AVX2, FMA: three-operand forms),
// and the dynamic loader picks one at start-up (GCC's target_clones, an ifunc):
// one portable binary that runs the faster copy wherever the processor has it.
#pragma once

#include <string>

namespace jrgen::emit {

/// The preprocessor block that defines JRGEN_DISPATCH: target_clones for
/// x86-64-v3 and the baseline with GCC on x86-64 Linux when the file is not
/// already compiled for AVX2; nothing elsewhere, or with -DJRGEN_NO_DISPATCH.
std::string dispatch_macro();

/// `source` with "JRGEN_DISPATCH " before each function definition that
/// starts at column 0 and does floating-point work; the error helpers and
/// the accessors keep one copy.  Lines of declarations (ending in ';'
/// before any '{') are left alone.
std::string mark_dispatch(const std::string& source);

}  // namespace jrgen::emit
