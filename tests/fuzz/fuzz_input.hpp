// The input format of tests/fuzz/fuzz_urdf.cpp: URDF text, then optionally
// kCutsSeparator and the text of a --cuts file.  make_corpus.cmake writes the
// seeds in this format.
#pragma once

#include <string>

namespace jrgen::fuzz {

inline constexpr const char* kCutsSeparator = "\n<!--jrgen-fuzz-cuts-->\n";

struct Input {
  std::string urdf;
  std::string cuts;
  bool has_cuts = false;
};

inline Input split_input(const std::string& text) {
  const std::string sep = kCutsSeparator;
  const std::size_t at = text.find(sep);
  if (at == std::string::npos) return {text, "", false};
  return {text.substr(0, at), text.substr(at + sep.size()), true};
}

}  // namespace jrgen::fuzz
