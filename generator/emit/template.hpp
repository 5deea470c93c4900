// Minimal text templates: "{{name}}" is replaced by the value of `name`.
// A template line holding only "{{name}}" (plus indentation) is replaced by
// the value's lines, each indented like the placeholder; an empty value
// removes the line and one blank line after it.  Unknown or unused names are
// errors, so templates and emitter cannot drift apart silently.
#pragma once

#include <map>
#include <string>
#include <string_view>

namespace jrgen::emit {

using TemplateValues = std::map<std::string, std::string>;

/// Throws std::runtime_error naming the template and the placeholder.
std::string render_template(std::string_view template_name, std::string_view text,
                            const TemplateValues& values);

/// The templates compiled into the binary (templates/*.tmpl).
std::string_view template_text(std::string_view file_name);

}  // namespace jrgen::emit
