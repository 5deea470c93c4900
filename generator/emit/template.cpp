#include "emit/template.hpp"

#include <set>
#include <stdexcept>

namespace jrgen::emit {

std::string render_template(std::string_view template_name, std::string_view text,
                            const TemplateValues& values) {
  std::string out;
  std::set<std::string> used;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    const std::string_view line = text.substr(pos, eol - pos);
    pos = eol + 1;
    // Whole-line placeholder: indent every line of the value.
    const std::size_t first = line.find_first_not_of(' ');
    if (first != std::string_view::npos && line.substr(first, 2) == "{{" &&
        line.size() >= 4 && line.substr(line.size() - 2) == "}}" &&
        line.find("{{", first + 2) == std::string_view::npos) {
      const std::string name(line.substr(first + 2, line.size() - first - 4));
      const auto it = values.find(name);
      if (it == values.end())
        throw std::runtime_error(std::string(template_name) + ": no value for {{" + name + "}}");
      used.insert(name);
      const std::string& value = it->second;
      if (value.empty()) {
        // The line goes, and with it one blank line after it, so an absent
        // section leaves no double blank line behind.
        if (pos < text.size() && text[pos] == '\n') ++pos;
        continue;
      }
      std::size_t vpos = 0;
      while (vpos < value.size()) {
        std::size_t veol = value.find('\n', vpos);
        if (veol == std::string::npos) veol = value.size();
        const std::string_view vline = std::string_view(value).substr(vpos, veol - vpos);
        if (!vline.empty()) {
          out.append(line.substr(0, first));
          out.append(vline);
        }
        out += '\n';
        vpos = veol + 1;
      }
      continue;
    }
    // Inline placeholders.
    std::size_t cur = 0;
    while (true) {
      const std::size_t open = line.find("{{", cur);
      if (open == std::string_view::npos) {
        out.append(line.substr(cur));
        break;
      }
      const std::size_t close = line.find("}}", open);
      if (close == std::string_view::npos)
        throw std::runtime_error(std::string(template_name) + ": unterminated {{");
      out.append(line.substr(cur, open - cur));
      const std::string name(line.substr(open + 2, close - open - 2));
      const auto it = values.find(name);
      if (it == values.end())
        throw std::runtime_error(std::string(template_name) + ": no value for {{" + name + "}}");
      used.insert(name);
      out.append(it->second);
      cur = close + 2;
    }
    if (eol < text.size()) out += '\n';
  }
  for (const auto& [name, value] : values)
    if (!used.count(name))
      throw std::runtime_error(std::string(template_name) + ": value {{" + name + "}} is never used");
  return out;
}

}  // namespace jrgen::emit
