// Processor dispatch: see dispatch.hpp.
#include "emit/dispatch.hpp"

#include <regex>
#include <set>
#include <sstream>
#include <vector>

namespace jrgen::emit {

std::string dispatch_macro() {
  return "// Processor dispatch (docs/specialization.md): compiled without -march for\n"
         "// x86-64, each routine below marked JRGEN_DISPATCH is compiled twice, for\n"
         "// x86-64-v3 (AVX2, FMA) and for the baseline, and the dynamic loader picks\n"
         "// the copy this processor runs (GCC target_clones).  The copies differ only\n"
         "// in rounding (fused multiply-adds).  -DJRGEN_NO_DISPATCH keeps one copy.\n"
         "#if !defined(JRGEN_NO_DISPATCH) && defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \\\n"
         "    defined(__linux__) && !defined(__AVX2__)\n"
         "#define JRGEN_DISPATCH __attribute__((target_clones(\"arch=x86-64-v3\", \"default\")))\n"
         "#define JRGEN_DISPATCHED 1\n"
         "#else\n"
         "#define JRGEN_DISPATCH\n"
         "#endif\n";
}

namespace {

// Routines that run only on a failure, or return a stored value: one copy.
bool cold(const std::string& name) {
  static const std::set<std::string> names = {
      "fail", "fail_row", "non_finite", "non_finite_matrix", "not_positive_definite", "constraints_singular",
      "last_error", "last_solve_regularized"};
  return names.count(name) > 0;
}

// True when the definition that starts at line i reaches '{' before ';'.
bool is_definition(const std::vector<std::string>& lines, std::size_t i) {
  for (std::size_t k = i; k < lines.size() && k < i + 8; ++k)
    for (char c : lines[k]) {
      if (c == '{') return true;
      if (c == ';') return false;
    }
  return false;
}

}  // namespace

std::string mark_dispatch(const std::string& source) {
  static const std::regex signature(R"(^(JRGEN_STEP )?(void|int|double) ([A-Za-z_][A-Za-z0-9_]*)\()");
  std::vector<std::string> lines;
  std::istringstream in(source);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::string out;
  out.reserve(source.size() + 4096);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    const bool candidate = l.rfind("void ", 0) == 0 || l.rfind("int ", 0) == 0 || l.rfind("double ", 0) == 0 ||
                           l.rfind("JRGEN_STEP ", 0) == 0;
    std::smatch m;
    if (candidate && std::regex_search(l, m, signature) && !cold(m[3].str()) && is_definition(lines, i))
      out += "JRGEN_DISPATCH ";
    out += lines[i];
    if (i + 1 < lines.size() || (!source.empty() && source.back() == '\n')) out += '\n';
  }
  return out;
}

}  // namespace jrgen::emit
