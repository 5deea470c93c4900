#include "ir/ir.hpp"

#include "ir/error.hpp"

namespace jrgen {

namespace {
std::string format_error(const ir::SourceLocation& where, const std::string& element,
                         const std::string& name, const std::string& what) {
  std::string out;
  if (!where.file.empty()) {
    out.append(where.file);
    if (where.line > 0) {
      out.push_back(':');
      out.append(std::to_string(where.line));
    }
    out.append(": ");
  }
  if (!element.empty()) {
    out.push_back('<');
    out.append(element);
    out.push_back('>');
    if (!name.empty()) {
      out.append(" '");
      out.append(name);
      out.push_back('\'');
    }
    out.append(": ");
  }
  out += what;
  return out;
}
}  // namespace

std::string one_line(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u != 0x7f) out.push_back(c);
    else if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c == '\t') out += "\\t";
    else {
      constexpr const char* kHex = "0123456789abcdef";
      out += "\\x";
      out.push_back(kHex[u >> 4]);
      out.push_back(kHex[u & 0xf]);
    }
  }
  return out;
}

Error::Error(const ir::SourceLocation& where, const std::string& element, const std::string& name,
             const std::string& what)
    : std::runtime_error(one_line(format_error(where, element, name, what))) {}

namespace ir {

int joint_nv(JointType type) {
  switch (type) {
    case JointType::Fixed: return 0;
    case JointType::Revolute:
    case JointType::Continuous:
    case JointType::Prismatic: return 1;
    case JointType::Ball:
    case JointType::Planar: return 3;
    case JointType::Floating: return 6;
  }
  return 0;
}

int joint_nq(JointType type) {
  switch (type) {
    case JointType::Ball: return 4;
    case JointType::Floating: return 7;
    default: return joint_nv(type);
  }
}

const char* joint_type_name(JointType type) {
  switch (type) {
    case JointType::Fixed: return "fixed";
    case JointType::Revolute: return "revolute";
    case JointType::Continuous: return "continuous";
    case JointType::Prismatic: return "prismatic";
    case JointType::Floating: return "floating";
    case JointType::Planar: return "planar";
    case JointType::Ball: return "ball";
  }
  return "?";
}

int cut_rows(CutType type) {
  switch (type) {
    case CutType::Spherical: return 3;
    case CutType::Revolute: return 5;
    case CutType::Prismatic: return 5;
    case CutType::Cylindrical: return 4;
    case CutType::Universal: return 4;
    case CutType::Fixed: return 6;
    case CutType::Distance: return 1;
    case CutType::Mimic: return 1;
  }
  return 0;
}

const char* cut_type_name(CutType type) {
  switch (type) {
    case CutType::Spherical: return "spherical";
    case CutType::Revolute: return "revolute";
    case CutType::Prismatic: return "prismatic";
    case CutType::Cylindrical: return "cylindrical";
    case CutType::Universal: return "universal";
    case CutType::Fixed: return "fixed";
    case CutType::Distance: return "distance";
    case CutType::Mimic: return "mimic";
  }
  return "?";
}

int Robot::find_link(const std::string& link_name) const {
  for (std::size_t i = 0; i < links.size(); ++i)
    if (links[i].name == link_name) return static_cast<int>(i);
  return -1;
}

int Robot::nq() const {
  int n = 0;
  for (const Joint& j : joints) n += joint_nq(j.type);
  return n;
}

int Robot::nv() const {
  int n = 0;
  for (const Joint& j : joints) n += joint_nv(j.type);
  return n;
}

}  // namespace ir
}  // namespace jrgen
