#include "emit/code_writer.hpp"

namespace jrgen::emit {

void CodeWriter::line(std::string_view text) {
  if (!text.empty()) {
    out_.append(static_cast<std::size_t>(indent_) * 2, ' ');
    out_ += text;
  }
  out_ += '\n';
  ++lines_;
}

void CodeWriter::comment(std::string_view text) {
  std::string s = "//";
  if (!text.empty()) {
    s += ' ';
    s += text;
  }
  line(s);
}

CodeWriter::Scope::Scope(CodeWriter& w, std::string_view head, std::string tail)
    : w_(w), tail_(std::move(tail)) {
  w_.line(head.empty() ? std::string("{") : std::string(head) + " {");
  ++w_.indent_;
}

CodeWriter::Scope::~Scope() {
  --w_.indent_;
  w_.line("}" + tail_);
}

}  // namespace jrgen::emit
