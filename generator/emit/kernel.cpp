#include "emit/kernel.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "emit/code_writer.hpp"

namespace jrgen::emit {

namespace {
std::string products(const std::vector<Term>& terms, std::size_t from, std::size_t to) {
  std::string s;
  for (std::size_t k = from; k < to; ++k) {
    if (k > from) s += " + ";
    s += terms[k].a + " * " + terms[k].b;
  }
  return s;
}

// Partial sums of more than kMaxTermsPerStatement products: "type acc =
// chunk;" then "acc += chunk;".  Returns the name holding the sum.
std::string partial_sums(Kernel::Unit& u, const std::string& indent, const std::vector<Term>& terms,
                         const std::string& acc, const std::string& type = "double") {
  for (std::size_t from = 0; from < terms.size(); from += kMaxTermsPerStatement) {
    const std::size_t to = std::min(terms.size(), from + kMaxTermsPerStatement);
    u.lines.push_back(indent + (from == 0 ? type + " " + acc + " = " : acc + " += ") + products(terms, from, to) +
                      ";");
    ++u.statements;
  }
  return acc;
}
}  // namespace

void Kernel::update(Unit& u, const std::string& indent, const std::string& target, const std::string& base,
                    const std::vector<Term>& terms, const Scale& scale, const std::string& decl,
                    const std::string& acc) {
  ops.mul += static_cast<long long>(terms.size());
  // With no base the sum is negated, not subtracted from anything: one
  // addition fewer (a sign change is not counted).
  ops.add += static_cast<long long>(terms.size()) - (base.empty() && !terms.empty() ? 1 : 0);
  if (!scale.empty()) (scale.divide ? ops.div : ops.mul) += 1;
  if (terms.empty()) {
    if (decl.empty() && !scale.empty() && target == base)
      u.lines.push_back(indent + target + (scale.divide ? " /= " : " *= ") + scale.by + ";");
    else u.lines.push_back(indent + decl + target + " = " + base + (scale.empty() ? "" : scale.applied()) + ";");
    ++u.statements;
    return;
  }
  std::string value;
  const bool scoped = terms.size() > kMaxTermsPerStatement && decl.empty();
  std::string in = indent;
  if (scoped) {
    u.lines.push_back(indent + "{");
    in += "  ";
  }
  const std::string minus = base.empty() ? "-" : base + " - ";
  if (terms.size() <= kMaxTermsPerStatement) {
    const std::string sum = products(terms, 0, terms.size());
    value = terms.size() == 1 && !base.empty() ? minus + sum : minus + "(" + sum + ")";
  } else {
    value = minus + partial_sums(u, in, terms, acc);
  }
  u.lines.push_back(in + decl + target + " = " + (scale.empty() ? value : "(" + value + ")" + scale.applied()) + ";");
  ++u.statements;
  if (scoped) u.lines.push_back(indent + "}");
}

void Kernel::update_pair(Unit& u, const std::string& indent, const std::string& target, const std::string& base,
                         const std::vector<Term>& terms, const Scale& scale) {
  ops.mul += 2 * static_cast<long long>(terms.size());
  if (!scale.empty()) (scale.divide ? ops.div : ops.mul) += 2;
  // With no base the sum is negated, as in update(): one addition fewer per lane.
  ops.add += 2 * static_cast<long long>(terms.size()) - (base.empty() && !terms.empty() ? 2 : 0);
  auto store = [&](const std::string& in, const std::string& value) {
    const std::string scaled =
        scale.empty() ? value : terms.empty() ? value + scale.applied() : "(" + value + ")" + scale.applied();
    u.lines.push_back(in + "jr::store2(" + target + ", " + scaled + ");");
    ++u.statements;
  };
  const std::string minus = base.empty() ? "-" : base + " - ";
  if (terms.size() <= kMaxTermsPerStatement) {
    const std::string sum = products(terms, 0, terms.size());
    store(indent, terms.empty() ? base : terms.size() == 1 && !base.empty() ? minus + sum : minus + "(" + sum + ")");
    return;
  }
  // Partial sums, as update() makes them (same order of additions).
  u.lines.push_back(indent + "{");
  const std::string in = indent + "  ";
  const std::string acc = partial_sums(u, in, terms, "s", "jr::v2d");
  store(in, base.empty() ? "(-" + acc + ")" : base + " - " + acc);
  u.lines.push_back(indent + "}");
}

void Kernel::assign_sum(Unit& u, const std::string& indent, const std::string& target, const std::vector<Term>& terms,
                        const std::string& tail) {
  ops.mul += static_cast<long long>(terms.size());
  ops.add += static_cast<long long>(terms.size()) - 1 + (tail.empty() ? 0 : 1);
  const std::string minus_tail = tail.empty() ? "" : " - " + tail;
  if (terms.size() <= kMaxTermsPerStatement) {
    u.lines.push_back(indent + target + " = " + products(terms, 0, terms.size()) + minus_tail + ";");
    ++u.statements;
    return;
  }
  u.lines.push_back(indent + "{");
  const std::string acc = partial_sums(u, indent + "  ", terms, "s");
  u.lines.push_back(indent + "  " + target + " = " + acc + minus_tail + ";");
  u.lines.push_back(indent + "}");
  ++u.statements;
}

void Kernel::add_sum(Unit& u, const std::string& indent, const std::string& target, const std::vector<Term>& terms) {
  ops.mul += static_cast<long long>(terms.size());
  ops.add += static_cast<long long>(terms.size());
  for (std::size_t from = 0; from < terms.size(); from += kMaxTermsPerStatement) {
    const std::size_t to = std::min(terms.size(), from + kMaxTermsPerStatement);
    u.lines.push_back(indent + target + " += " + products(terms, from, to) + ";");
    ++u.statements;
  }
}

std::string Kernel::functions(const std::string& name, const std::string& params, const std::string& args,
                              bool checked, const std::string& doc) const {
  std::vector<std::vector<const Unit*>> parts(1);
  std::size_t count = 0;
  for (const Unit& u : units) {
    if (count > 0 && count + u.statements > kMaxStatementsPerFunction) {
      parts.emplace_back();
      count = 0;
    }
    parts.back().push_back(&u);
    count += u.statements;
  }
  const std::string ret = checked ? "int" : "void";
  // Every array of a kernel is a distinct workspace buffer: __restrict lets
  // the compiler keep values in registers across stores to the others.
  std::string restricted;
  for (std::size_t pos = 0; pos < params.size(); ++pos) {
    restricted += params[pos];
    if (params[pos] == '*') restricted += " __restrict";
  }
  std::vector<std::string> names;  // "double* L" -> "L"
  for (std::size_t pos = 0; pos < params.size();) {
    std::size_t end = params.find(',', pos);
    if (end == std::string::npos) end = params.size();
    const std::string piece = params.substr(pos, end - pos);
    names.push_back(piece.substr(piece.find_last_of(" *") + 1));
    pos = end + 1;
  }
  CodeWriter w;
  auto body = [&](const std::vector<const Unit*>& part) {
    for (const std::string& n : names) {
      bool used = false;
      for (const Unit* u : part)
        for (const std::string& l : u->lines) used = used || l.find(n + "[") != std::string::npos;
      if (!used) w.line("(void)" + n + ";");
    }
    std::size_t since_fence = 0;  // products written since the last fence
    for (const Unit* u : part) {
      if (fence_every > 0 && since_fence >= fence_every) {
        w.line(kFenceStatement);
        since_fence = 0;
      }
      for (const std::string& l : u->lines) {
        w.line(l);
        for (std::size_t at = l.find(" * "); at != std::string::npos; at = l.find(" * ", at + 3)) ++since_fence;
      }
    }
  };
  for (const std::string& d : split_lines(doc)) w.comment(d);
  if (parts.size() == 1) {
    CodeWriter::Scope f(w, ret + " " + name + "(" + restricted + ")");
    body(parts[0]);
    if (checked) w.line("return 0;");
  } else {
    for (std::size_t p = 0; p < parts.size(); ++p) {
      CodeWriter::Scope f(w, fmt::format("{} {}_part{}({})", ret, name, p, restricted));
      body(parts[p]);
      if (checked) w.line("return 0;");
    }
    w.blank();
    CodeWriter::Scope f(w, ret + " " + name + "(" + restricted + ")");
    for (std::size_t p = 0; p < parts.size(); ++p) {
      if (checked) w.line(fmt::format("if (const int s = {}_part{}({})) return s;", name, p, args));
      else w.line(fmt::format("{}_part{}({});", name, p, args));
    }
    if (checked) w.line("return 0;");
  }
  std::string out = w.take();
  if (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

std::string strip_fences(const std::string& code) {
  std::string out;
  for (const std::string& line : split_lines(code)) {
    const std::size_t first = line.find_first_not_of(' ');
    if (first != std::string::npos && line.compare(first, std::string::npos, kFenceStatement) == 0) continue;
    out += line;
    out += '\n';
  }
  if (!out.empty()) out.pop_back();  // split_lines gives one line more than newlines
  return out;
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    out.push_back(text.substr(pos, eol - pos));
    pos = eol + 1;
  }
  return out;
}

}  // namespace jrgen::emit
