// Indented text output for the emitter.  Scopes are RAII guards (as LLVM's
// TableGen CodeGenHelpers), so braces always balance and indentation is
// correct by construction; no trailing blanks are ever written.
#pragma once

#include <string>
#include <string_view>

namespace jrgen::emit {

class CodeWriter {
 public:
  explicit CodeWriter(int indent = 0) : indent_(indent) {}

  /// One line at the current indentation (an empty line stays empty).
  void line(std::string_view text);
  /// A comment line "// text".
  void comment(std::string_view text);
  void blank() { out_ += '\n'; }

  const std::string& str() const { return out_; }
  std::string take() { return std::move(out_); }
  std::size_t lines() const { return lines_; }

  /// `head {` ... `}` + tail, indented inside.
  class Scope {
   public:
    Scope(CodeWriter& w, std::string_view head, std::string tail = "");
    ~Scope();
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    CodeWriter& w_;
    std::string tail_;
  };

 private:
  std::string out_;
  int indent_;
  std::size_t lines_ = 0;
};

}  // namespace jrgen::emit
