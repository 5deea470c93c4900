// The namespace of a generated solver: sanitize_identifier() derives it from
// a robot name, invalid_namespace() checks a --namespace (docs/interface.md
// section 1; declared in emit/emitter.hpp).
#include <algorithm>
#include <iterator>
#include <string>
#include <string_view>

#include "emit/emitter.hpp"

namespace jrgen::emit {

namespace {

bool is_keyword(std::string_view name) {
  static const std::string_view kKeywords[] = {
      "alignas", "alignof", "and", "and_eq", "asm", "auto", "bitand", "bitor", "bool", "break",
      "case", "catch", "char", "char8_t", "char16_t", "char32_t", "class", "compl", "concept",
      "const", "consteval", "constexpr", "constinit", "const_cast", "continue", "co_await",
      "co_return", "co_yield", "decltype", "default", "delete", "do", "double", "dynamic_cast",
      "else", "enum", "explicit", "export", "extern", "false", "float", "for", "friend", "goto",
      "if", "inline", "int", "long", "mutable", "namespace", "new", "noexcept", "not", "not_eq",
      "nullptr", "operator", "or", "or_eq", "private", "protected", "public", "register",
      "reinterpret_cast", "requires", "return", "short", "signed", "sizeof", "static",
      "static_assert", "static_cast", "struct", "switch", "template", "this", "thread_local",
      "throw", "true", "try", "typedef", "typeid", "typename", "union", "unsigned", "using",
      "virtual", "void", "volatile", "wchar_t", "while", "xor", "xor_eq", "final", "override",
      "import", "module"};
  return std::find(std::begin(kKeywords), std::end(kKeywords), name) != std::end(kKeywords);
}

// Namespaces the generated code cannot take: the standard library's and
// POSIX's ([namespace.std], [namespace.posix]) and the runtime's.
bool is_taken_namespace(std::string_view name) { return name == "std" || name == "posix" || name == "jr"; }

bool is_identifier_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

}  // namespace

std::string invalid_namespace(std::string_view name) {
  if (name.empty()) return "it is empty";
  if (name[0] >= '0' && name[0] <= '9') return "a C++ identifier cannot start with a digit";
  for (char c : name)
    if (!is_identifier_char(c)) return "a C++ identifier holds only letters, digits and '_'";
  if (is_keyword(name)) return "it is a C++ keyword";
  if (is_taken_namespace(name)) return "that namespace belongs to the standard library, POSIX or jrgen's runtime";
  if (name.find("__") != std::string_view::npos) return "identifiers containing \"__\" are reserved";
  if (name[0] == '_') return "global names starting with '_' are reserved";
  return "";
}

std::string sanitize_identifier(std::string_view name) {
  std::string out;
  for (char c : name) {
    const char d = is_identifier_char(c) ? c : '_';
    if (d == '_' && (out.empty() || out.back() == '_')) continue;  // no leading '_', no "__"
    out += d;
  }
  if (out.empty() || (out[0] >= '0' && out[0] <= '9')) out = "robot_" + out;
  if (is_keyword(out) || is_taken_namespace(out)) out += "_";
  return out;
}

}  // namespace jrgen::emit
