// The one exception type of the generator.  Every stage throws it with a
// location; main() prints what() as one line and exits non-zero.
#pragma once

#include <stdexcept>
#include <string>

#include "ir/ir.hpp"

namespace jrgen {

/// Formats as "file:line: <element> 'name': what is wrong" (STYLE.md section 5);
/// the line is left out when unknown, the element part when empty.
class Error : public std::runtime_error {
 public:
  Error(const ir::SourceLocation& where, const std::string& element, const std::string& name,
        const std::string& what);
  /// An error without a model element (options, files).
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace jrgen
