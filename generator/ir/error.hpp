// The one exception type of the generator.  Every stage throws it with a
// location; main() prints what() as one line and exits non-zero.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "ir/ir.hpp"

namespace jrgen {

/// `text` with every control character written as an escape (\n, \r, \t,
/// \xHH), so that a message quoting the user's text stays one line.
std::string one_line(const std::string& text);

/// Formats as "file:line: <element> 'name': what is wrong" (docs/conventions.md, "Errors");
/// the line is left out when unknown, the element part when empty.  Always one
/// line: control characters in any part are escaped (one_line).
/// The candidate closest to `word` when it looks like a misspelling of it
/// (edit distance at most 2, and less than half of the word's length; case
/// ignored), else "".  For "did you mean ..." in messages.
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);

class Error : public std::runtime_error {
 public:
  Error(const ir::SourceLocation& where, const std::string& element, const std::string& name,
        const std::string& what);
  /// An error without a model element (options, files).
  explicit Error(const std::string& what) : std::runtime_error(one_line(what)) {}
};

}  // namespace jrgen
