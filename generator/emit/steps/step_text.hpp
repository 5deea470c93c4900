// Text shared by the units that write the steps of Section 4.3 (internal to
// the emit stage): how a step states its operation count, comments made of
// free text, and the way out of the solver's namespaces for a runtime header.
#pragma once

#include <fmt/format.h>

#include <string>
#include <vector>

#include "emit/code_writer.hpp"
#include "emit/emitter.hpp"
#include "emit/kernel.hpp"

namespace jrgen::emit {

/// "Ops: A add, M mul, D div." (with `sqrt`: "..., D div, S sqrt."): the count
/// of a step as its comment states it, as counted in OpCount.
inline std::string ops_text(const OpCount& o, bool sqrt = false) {
  return sqrt ? fmt::format("Ops: {} add, {} mul, {} div, {} sqrt.", o.add, o.mul, o.div, o.sqrt)
              : fmt::format("Ops: {} add, {} mul, {} div.", o.add, o.mul, o.div);
}

/// `text`, each line behind "// ".
inline std::string as_comment(const std::string& text) {
  std::string out;
  for (const std::string& line : split_lines(text)) out += (out.empty() ? "// " : "\n// ") + line;
  return out;
}

/// A step function whose body calls the runtime's loops: each line of `doc`
/// as a comment ("" for none), then `signature {`, the `body` statements one
/// a line, `}` (CodeWriter); no newline at the end.
inline std::string call_function(const std::string& doc, const std::string& signature,
                                 const std::vector<std::string>& body) {
  CodeWriter w;
  if (!doc.empty())
    for (const std::string& line : split_lines(doc)) w.comment(line);
  {
    CodeWriter::Scope f(w, signature);
    for (const std::string& statement : body) w.line(statement);
  }
  std::string out = w.take();
  out.pop_back();
  return out;
}

/// Leaves the solver's namespaces (`name_space` and the anonymous one),
/// includes `include_line` at file scope and enters them again: the runtime
/// headers of the table-driven and dense loops (the template includes
/// jrgen/runtime.hpp only).
inline std::string include_at_file_scope(const std::string& name_space, const std::string& include_line) {
  return fmt::format("}}  // namespace\n}}  // namespace {0}\n{1}\nnamespace {0} {{\nnamespace {{\n\n", name_space,
                     include_line);
}

}  // namespace jrgen::emit
