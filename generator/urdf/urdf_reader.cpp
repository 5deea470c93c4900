// URDF reader: URDF (+ cut joints) -> ir::Robot.  See urdf_reader.hpp.
//
// Pipeline of read_robot_string():
//   1. TinyXML parses the text (malformed XML is reported with its line).
//   2. Pre-pass over <robot>: names, types, links referenced, numbers (finite,
//      right count), mass and inertia, axes; then the tree checks (one parent
//      per link, no cycles, one root).  Every error names file and line.
//   3. A cleaned copy of the document goes to urdfdom: links with their
//      <inertial> only, joints with parent/child/origin/axis/dynamics only,
//      ball joints rewritten as floating (urdfdom does not know "ball"), a
//      dummy <limit> where urdfdom insists on one.  Everything we ignore
//      (visuals, collisions, limits, mimic, transmissions, gazebo) is left out,
//      so urdfdom cannot fail on it.  console_bridge is silenced meanwhile.
//      (<mimic> is read by the pre-pass: step 5.)
//   4. ir::Robot is assembled from urdfdom's values, links in document order,
//      joints in user order (depth-first from the root, children in document
//      order of their joint elements).
//   5. Cut joints: <loop_joint> and <drake:ball_constraint>, document order;
//      then each joint's <mimic> as a one-row cut (CutType::Mimic); then the
//      force elements <spring>, <joint_spring>, <joint_force> (section 2b).
#include "urdf/urdf_reader.hpp"

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

#include "ir/error.hpp"

namespace jrgen::urdf {
namespace {

// ---------------------------------------------------------------------------
// Locations, owners and errors
// ---------------------------------------------------------------------------

/// The named model element a checked value belongs to, for messages:
/// "<joint> 'knee'".  `element` is the tag without brackets.
struct Owner {
  std::string element;
  std::string name;
};

/// One parsed XML document and the name it is reported under.
struct Doc {
  std::string file;  ///< as given by the caller (path or display name)

  ir::SourceLocation at(const TiXmlNode* node) const {
    return ir::SourceLocation{file, node != nullptr ? node->Row() : 0};
  }
  [[noreturn]] void fail(const TiXmlNode* node, const Owner& owner, const std::string& what) const {
    throw Error(at(node), owner.element, owner.name, what);
  }
};

std::string format_number(double x) {
  std::ostringstream out;
  out.imbue(std::locale::classic());
  out.precision(6);
  out << x;
  return out.str();
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

/// "; did you mean 'x'?" when `word` looks like a misspelling of one of
/// `names`, else "".
std::string did_you_mean(const std::string& word, const std::vector<std::string>& names) {
  const std::string near = closest_match(word, names);
  return near.empty() ? "" : "; did you mean " + quote(near) + "?";
}

const char* attribute(const TiXmlElement* e, const char* name) {
  return e != nullptr ? e->Attribute(name) : nullptr;
}

bool is_tag(const TiXmlElement* e, const char* tag) { return std::strcmp(e->Value(), tag) == 0; }

// ---------------------------------------------------------------------------
// Numbers
// ---------------------------------------------------------------------------

enum class NumberStatus { Ok, NotANumber, NotFinite, OutOfRange };

/// Parses one token as a double in the C locale.  Accepts an optional '+'.
NumberStatus parse_number(std::string_view token, double& out) {
  if (token.size() > 1 && token.front() == '+' && token[1] != '-' && token[1] != '+')
    token.remove_prefix(1);
  const char* first = token.data();
  const char* last = first + token.size();
  const auto [ptr, ec] = std::from_chars(first, last, out, std::chars_format::general);
  if (ec == std::errc::result_out_of_range) return NumberStatus::OutOfRange;
  if (ec != std::errc() || ptr != last) return NumberStatus::NotANumber;
  if (!std::isfinite(out)) return NumberStatus::NotFinite;
  return NumberStatus::Ok;
}

std::vector<std::string_view> split_whitespace(std::string_view s) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  while (i < s.size()) {
    while (i < s.size() && space(s[i])) ++i;
    const std::size_t start = i;
    while (i < s.size() && !space(s[i])) ++i;
    if (i > start) tokens.push_back(s.substr(start, i - start));
  }
  return tokens;
}

/// Reads attribute `attr` of `e` as a list of finite numbers.  nullopt when
/// the attribute is absent; `count` >= 0 requires exactly that many numbers.
std::optional<std::vector<double>> read_numbers(const Doc& doc, const TiXmlElement* e,
                                                const char* attr, const Owner& owner,
                                                int count = -1) {
  const char* text = attribute(e, attr);
  if (text == nullptr) return std::nullopt;
  const std::string where =
      "<" + std::string(e->Value()) + " " + attr + "=\"" + std::string(text) + "\">";
  std::vector<double> values;
  for (const std::string_view token : split_whitespace(text)) {
    double x = 0.0;
    switch (parse_number(token, x)) {
      case NumberStatus::Ok:
        break;
      case NumberStatus::NotANumber:
        doc.fail(e, owner,
                 where + ": " + quote(std::string(token)) + " is not a number" +
                     (token.find('$') != std::string_view::npos
                          ? "; this looks like unexpanded xacro, run xacro first"
                      : token.find(',') != std::string_view::npos
                          ? "; URDF separates numbers by spaces and writes decimals with '.'"
                      : token.find('&') != std::string_view::npos || token.back() == ';'  // TinyXML drops '&'
                          ? "; jrgen does not expand XML entities (<!ENTITY> in a <!DOCTYPE>): write the number"
                          : "; write a number such as 0.5"));
      case NumberStatus::NotFinite:
        doc.fail(e, owner,
                 where + ": " + quote(std::string(token)) +
                     " is not a finite number; use finite values");
      case NumberStatus::OutOfRange:
        doc.fail(e, owner,
                 where + ": " + quote(std::string(token)) +
                     " is out of the range of double precision; check the value and its units");
    }
    values.push_back(x);
  }
  if (count >= 0 && static_cast<int>(values.size()) != count)
    doc.fail(e, owner,
             where + ": expected " + std::to_string(count) + " numbers, got " +
                 std::to_string(values.size()));
  if (count < 0 && values.empty()) doc.fail(e, owner, where + ": expected a number");
  return values;
}

/// Attribute names that hold numbers in URDF (and in our extensions).
bool is_numeric_attribute(const char* name) {
  // clang-format off
  static const std::set<std::string, std::less<>> names = {
      "xyz", "rpy", "value", "ixx", "ixy", "ixz", "iyy", "iyz", "izz",
      "damping", "friction", "lower", "upper", "effort", "velocity",
      "k_position", "k_velocity", "soft_lower_limit", "soft_upper_limit",
      "multiplier", "offset", "rising", "falling", "reference_position",
      "radius", "length", "size", "scale", "rgba"};
  // clang-format on
  return names.find(std::string_view(name)) != names.end();
}

/// Elements of URDF (and of our extensions) whose attributes hold numbers.
/// Other tags (simulator extras such as pr2's <verbose value="Yes">) are
/// not checked.
bool is_numeric_element(const char* tag) {
  // clang-format off
  static const std::set<std::string, std::less<>> tags = {
      "origin", "axis", "mass", "inertia", "dynamics", "limit", "safety_controller",
      "calibration", "mimic", "box", "cylinder", "sphere", "capsule", "mesh", "color",
      "child_origin", "child_axis", "distance",
      "drake:ball_constraint_p_AP", "drake:ball_constraint_p_BQ"};
  // clang-format on
  return tags.find(std::string_view(tag)) != tags.end();
}

/// Checks every numeric attribute of URDF elements in the subtree of `e`:
/// numbers only, all finite ("NaN or inf anywhere numeric").
void check_numbers_in(const Doc& doc, const TiXmlElement* e, const Owner& owner) {
  if (is_numeric_element(e->Value()))
    for (const TiXmlAttribute* a = e->FirstAttribute(); a != nullptr; a = a->Next())
      if (is_numeric_attribute(a->Name())) read_numbers(doc, e, a->Name(), owner);
  for (const TiXmlElement* c = e->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
    check_numbers_in(doc, c, owner);
}

Eigen::Vector3d read_vec3(const Doc& doc, const TiXmlElement* e, const char* attr,
                          const Owner& owner, const Eigen::Vector3d& fallback) {
  const auto v = read_numbers(doc, e, attr, owner, 3);
  if (!v) return fallback;
  return Eigen::Vector3d((*v)[0], (*v)[1], (*v)[2]);
}

std::optional<double> read_scalar(const Doc& doc, const TiXmlElement* e, const char* attr,
                                  const Owner& owner) {
  const auto v = read_numbers(doc, e, attr, owner, 1);
  if (!v) return std::nullopt;
  return (*v)[0];
}

/// URDF roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d rotation_from_rpy(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/// Pose from an element with xyz and rpy attributes (identity when absent).
ir::Pose read_pose(const Doc& doc, const TiXmlElement* e, const Owner& owner) {
  ir::Pose pose;
  if (e == nullptr) return pose;
  pose.p = read_vec3(doc, e, "xyz", owner, Eigen::Vector3d::Zero());
  pose.R = rotation_from_rpy(read_vec3(doc, e, "rpy", owner, Eigen::Vector3d::Zero()));
  return pose;
}

/// Reads <axis xyz> (or another element's xyz) and normalizes it; nullopt when
/// the element or its xyz attribute is absent.
std::optional<Eigen::Vector3d> read_axis(const Doc& doc, const TiXmlElement* e,
                                         const Owner& owner) {
  if (attribute(e, "xyz") == nullptr) return std::nullopt;
  const Eigen::Vector3d axis = read_vec3(doc, e, "xyz", owner, Eigen::Vector3d::UnitX());
  const double norm = axis.norm();
  if (!(norm > 1e-12))
    doc.fail(e, owner,
             "<" + std::string(e->Value()) +
                 " xyz> is the zero vector; give a direction, e.g. xyz=\"0 0 1\"");
  return Eigen::Vector3d(axis / norm);
}

// ---------------------------------------------------------------------------
// Misspelled elements and attributes (notes)
// ---------------------------------------------------------------------------

/// The child elements jrgen knows inside an element, for the misspelling
/// check; elements not listed here are not looked into.
const std::vector<std::string>* known_children(const std::string& tag) {
  static const std::map<std::string, std::vector<std::string>> known = {
      {"robot",
       {"link", "joint", "loop_joint", "drake:joint", "drake:ball_constraint", "spring", "joint_spring",
        "joint_force", "material", "gazebo", "transmission"}},
      {"link", {"inertial", "visual", "collision"}},
      {"inertial", {"origin", "mass", "inertia"}},
      {"joint", {"parent", "child", "origin", "axis", "limit", "dynamics", "mimic", "calibration",
                 "safety_controller"}},
      {"loop_joint", {"parent", "child", "origin", "child_origin", "axis", "child_axis", "distance"}}};
  const auto it = known.find(tag);
  return it == known.end() ? nullptr : &it->second;
}

/// The attributes jrgen reads (or URDF defines) on an element met by the
/// misspelling check.
const std::vector<std::string>* known_attributes(const std::string& tag) {
  static const std::map<std::string, std::vector<std::string>> known = {
      {"link", {"name"}},
      {"joint", {"name", "type"}},
      {"loop_joint", {"name", "type"}},
      {"origin", {"xyz", "rpy"}},
      {"child_origin", {"xyz", "rpy"}},
      {"axis", {"xyz"}},
      {"child_axis", {"xyz"}},
      {"mass", {"value"}},
      {"inertia", {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"}},
      {"parent", {"link"}},
      {"child", {"link"}},
      {"dynamics", {"damping", "friction"}},
      {"mimic", {"joint", "multiplier", "offset"}},
      {"limit", {"lower", "upper", "effort", "velocity"}},
      {"distance", {"value"}}};
  const auto it = known.find(tag);
  return it == known.end() ? nullptr : &it->second;
}

/// Notes for what URDF parsers silently ignore but is most likely a typo:
/// a child element or an attribute of `e` (and, recursively, of its known
/// children) that is unknown there and one or two letters from a known one,
/// as <inertail> or <origin xzy="...">: the model would load with a default
/// (no mass, the x axis, the identity pose).
void note_misspellings(const Doc& doc, const TiXmlElement* e, const Owner& owner, std::vector<std::string>& notes) {
  const std::string tag = e->Value();
  if (const std::vector<std::string>* attrs = known_attributes(tag))
    for (const TiXmlAttribute* a = e->FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string name = a->Name();
      if (std::find(attrs->begin(), attrs->end(), name) != attrs->end()) continue;
      const std::string near = closest_match(name, *attrs);
      if (!near.empty())
        notes.push_back(Error(doc.at(e), owner.element, owner.name,
                              "<" + tag + "> attribute '" + name + "' is not read (ignored); did you mean '" + near +
                                  "'?")
                            .what());
    }
  const std::vector<std::string>* children = known_children(tag);
  if (children == nullptr) return;
  for (const TiXmlElement* c = e->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
    const std::string child = c->Value();
    Owner inner = owner;
    if (tag == "robot") {
      const char* name = c->Attribute("name");
      inner = Owner{child, name != nullptr ? name : ""};
    }
    if (std::find(children->begin(), children->end(), child) != children->end()) {
      note_misspellings(doc, c, inner, notes);
      continue;
    }
    const std::string near = closest_match(child, *children);
    if (!near.empty())
      notes.push_back(Error(doc.at(c), inner.element, inner.name,
                            "<" + child + "> is not a URDF element inside <" + tag + "> and is ignored; did you mean <" +
                                near + ">?")
                          .what());
  }
}

// ---------------------------------------------------------------------------
// Files and XML
// ---------------------------------------------------------------------------

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw Error(ir::SourceLocation{path, 0}, "", "", "cannot read file: it is a folder; give the file in it");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw Error(
        ir::SourceLocation{path, 0}, "", "",
        std::string("cannot read file: ") + (err != 0 ? std::strerror(err) : "open failed") +
            (err == ENOENT ? "; check the path (relative to the folder jrgen runs in)" : ""));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(ir::SourceLocation{path, 0}, "", "", "cannot read file: read error");
  return text.str();
}

// What TinyXML would misreport ("Error document empty" for a binary file):
// an empty file, a NUL byte, or a first character that cannot start XML.
void check_xml_text(const Doc& doc, const std::string& xml) {
  const std::string fix = "give a URDF: an XML text file whose root element is <robot name=\"...\">";
  const std::size_t nul = xml.find('\0');
  if (nul != std::string::npos)
    throw Error(ir::SourceLocation{doc.file, 0}, "", "",
                fmt::format("not a text file (a NUL byte at offset {}); {}", nul, fix));
  std::size_t first = xml.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0;  // a UTF-8 byte order mark
  first = xml.find_first_not_of(" \t\r\n", first);
  if (first == std::string::npos)
    throw Error(ir::SourceLocation{doc.file, 0}, "", "", "the file is empty; " + fix);
  if (xml[first] != '<') {
    const int line = 1 + static_cast<int>(std::count(xml.begin(), xml.begin() + static_cast<long>(first), '\n'));
    throw Error(ir::SourceLocation{doc.file, line}, "", "",
                fmt::format("not XML: it starts with byte 0x{:02X} where '<' was expected; {}",
                            static_cast<unsigned char>(xml[first]), fix));
  }
}

// TinyXML ends a <!DOCTYPE> at its first '>', which may lie inside an
// internal subset ("<!DOCTYPE robot [ <!ENTITY l \"1\"> ]>"): the rest of the
// document was lost and the error read "no <robot> element" although there
// is one.  The declaration is blanked out (its newlines kept, so that line
// numbers stay right); its entities are not expanded (read_numbers says so).
std::string without_doctype(std::string xml) {
  const std::size_t at = xml.find("<!DOCTYPE");
  if (at == std::string::npos) return xml;
  int depth = 0;
  std::size_t end = at + 9;
  for (; end < xml.size(); ++end) {
    if (xml[end] == '[') ++depth;
    else if (xml[end] == ']') --depth;
    else if (xml[end] == '>' && depth <= 0) break;
  }
  if (end == xml.size()) return xml;  // unterminated: TinyXML reports it
  for (std::size_t k = at; k <= end; ++k)
    if (xml[k] != '\n') xml[k] = ' ';
  return xml;
}

void parse_xml(const Doc& doc, const std::string& xml, TiXmlDocument& out) {
  check_xml_text(doc, xml);
  out.Parse(without_doctype(xml).c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (out.Error()) {
    const int row = out.ErrorRow() > 0 ? out.ErrorRow() : 0;
    throw Error(ir::SourceLocation{doc.file, row}, "", "",
                std::string("malformed XML: ") + out.ErrorDesc() +
                    " (check that every element near this line is closed and every attribute value quoted)");
  }
}

/// " (is 'typ' meant to be type?)" when `e` has an attribute that looks
/// like a misspelling of the missing attribute `wanted`, else "".
std::string misspelled_attribute(const TiXmlElement* e, const std::string& wanted) {
  for (const TiXmlAttribute* a = e->FirstAttribute(); a != nullptr; a = a->Next())
    if (!closest_match(a->Name(), {wanted}).empty())
      return " (is " + quote(a->Name()) + " meant to be " + wanted + "?)";
  return "";
}

/// Name attribute of a model element; empty names are an error.
std::string required_name(const Doc& doc, const TiXmlElement* e) {
  const char* name = attribute(e, "name");
  if (name == nullptr || *name == '\0')
    doc.fail(e, Owner{e->Value(), ""},
             std::string("missing name attribute") + (name == nullptr ? misspelled_attribute(e, "name") : "") +
                 "; add name=\"...\" to this <" + e->Value() + ">");
  return name;
}

// ---------------------------------------------------------------------------
// Pre-pass over <robot>
// ---------------------------------------------------------------------------

struct LinkXml {
  std::string name;
  const TiXmlElement* xml = nullptr;
  int parent_joint = -1;  ///< index into RobotXml::joints (document order)
};

struct JointXml {
  std::string name;
  const TiXmlElement* xml = nullptr;
  ir::JointType type = ir::JointType::Fixed;
  int parent_link = -1;  ///< index into RobotXml::links
  int child_link = -1;
};

struct RobotXml {
  std::string name;
  const TiXmlElement* xml = nullptr;
  std::vector<LinkXml> links;    ///< document order
  std::vector<JointXml> joints;  ///< document order (<joint> and <drake:joint>)
  std::map<std::string, int> link_index;
  std::vector<const TiXmlElement*> cut_elements;  ///< <loop_joint>, <drake:ball_constraint>
  std::vector<const TiXmlElement*> force_elements;  ///< <spring>, <joint_spring>, <joint_force>
  std::vector<std::string> notes;  ///< misspelled elements and attributes (note_misspellings)
};

/// Checks <inertial>: mass present, finite and >= 0; inertia present with six
/// finite entries, positive semi-definite (symmetric by construction), and
/// if asked the triangle inequality.
void check_inertial(const Doc& doc, const TiXmlElement* inertial, const Owner& owner,
                    const ReadOptions& options) {
  const TiXmlElement* origin = inertial->FirstChildElement("origin");
  if (origin != nullptr) read_pose(doc, origin, owner);

  const TiXmlElement* mass_xml = inertial->FirstChildElement("mass");
  if (mass_xml == nullptr)
    doc.fail(inertial, owner, "<inertial> has no <mass value=\"...\"/>; add one");
  const auto mass = read_scalar(doc, mass_xml, "value", owner);
  if (!mass) doc.fail(mass_xml, owner, "<mass> has no value attribute; write <mass value=\"...\"/> (kg)");
  if (*mass < 0.0)
    doc.fail(mass_xml, owner,
             "negative mass " + format_number(*mass) + "; mass must be zero or positive");

  const TiXmlElement* inertia_xml = inertial->FirstChildElement("inertia");
  if (inertia_xml == nullptr)
    doc.fail(inertial, owner,
             "<inertial> has no <inertia ixx ixy ixz iyy iyz izz/>; add one (zeros for a point "
             "mass)");
  double v[6];
  const char* const keys[6] = {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"};
  for (int k = 0; k < 6; ++k) {
    const auto x = read_scalar(doc, inertia_xml, keys[k], owner);
    if (!x)
      doc.fail(inertia_xml, owner,
               std::string("<inertia> has no ") + keys[k] +
                   " attribute; give all six of ixx ixy ixz iyy iyz izz (kg m^2, 0 where zero)");
    v[k] = *x;
  }
  Eigen::Matrix3d I;
  I << v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5];

  // Tolerance relative to the size of the entries, as URDF files round their
  // numbers, plus an absolute 1e-12 kg m^2 for the near-zero inertias of
  // exported point masses (icub's head has ixz="2.40741e-35", all else 0).
  double scale = 0.0;
  for (double x : v) scale += std::abs(x);
  const double tol = 1e-6 * scale + 1e-12;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(I, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d m = eig.eigenvalues();  // ascending
  const std::string moments =
      format_number(m[0]) + ", " + format_number(m[1]) + ", " + format_number(m[2]);
  if (m[0] < -tol)
    doc.fail(inertia_xml, owner,
             "inertia is not positive semi-definite (principal moments " + moments +
                 "); check the signs of ixy, ixz, iyz (URDF wants the tensor entries, "
                 "-integral of x*y dm)");
  if (options.check_inertia_triangle && m[2] > m[0] + m[1] + tol)
    doc.fail(inertia_xml, owner,
             "principal moments of inertia " + moments +
                 " violate the triangle inequality (largest <= sum of the other two); check "
                 "ixx, iyy, izz");
}

void read_link_xml(const Doc& doc, const TiXmlElement* e, RobotXml& robot,
                   const ReadOptions& options) {
  LinkXml link;
  link.name = required_name(doc, e);
  link.xml = e;
  const Owner owner{"link", link.name};
  const auto found = robot.link_index.find(link.name);
  if (found != robot.link_index.end())
    doc.fail(e, owner,
             "duplicate link name (first defined at line " +
                 std::to_string(robot.links[found->second].xml->Row()) + "); rename one");
  check_numbers_in(doc, e, owner);
  if (const TiXmlElement* inertial = e->FirstChildElement("inertial"))
    check_inertial(doc, inertial, owner, options);
  robot.link_index.emplace(link.name, static_cast<int>(robot.links.size()));
  robot.links.push_back(std::move(link));
}

std::optional<ir::JointType> joint_type_from(std::string_view s) {
  if (s == "revolute") return ir::JointType::Revolute;
  if (s == "continuous") return ir::JointType::Continuous;
  if (s == "prismatic") return ir::JointType::Prismatic;
  if (s == "fixed") return ir::JointType::Fixed;
  if (s == "floating") return ir::JointType::Floating;
  if (s == "planar") return ir::JointType::Planar;
  if (s == "ball") return ir::JointType::Ball;
  return std::nullopt;
}

/// For an unknown joint type: the URDF type meant (other formats' names,
/// misspellings), as "; use type=\"x\" (...); ", else "; ".
std::string joint_type_hint(const std::string& type) {
  static const std::vector<std::pair<std::string, std::string>> synonyms = {
      {"hinge", "revolute"},      {"rotational", "revolute"}, {"rotary", "revolute"},
      {"slider", "prismatic"},    {"slide", "prismatic"},     {"linear", "prismatic"},
      {"sliding", "prismatic"},   {"spherical", "ball"},      {"free", "floating"},
      {"freejoint", "floating"},  {"weld", "fixed"},          {"rigid", "fixed"}};
  for (const auto& [other, urdf] : synonyms)
    if (type == other) return "; use type=\"" + urdf + "\" (the URDF name); ";
  if (type == "universal" || type == "cylindrical" || type == "screw" || type == "gearbox")
    return "; URDF has no such tree joint: build it from revolute and prismatic joints with light links "
           "between, or make it a <loop_joint>; ";
  const std::string near = closest_match(type, {"revolute", "continuous", "prismatic", "fixed", "floating", "planar",
                                                "ball"});
  if (!near.empty()) return " (did you mean " + quote(near) + "?); ";
  return "; ";
}

bool has_axis(ir::JointType type) {
  return type == ir::JointType::Revolute || type == ir::JointType::Continuous ||
         type == ir::JointType::Prismatic || type == ir::JointType::Planar;
}

/// Resolves <parent link> or <child link> of a joint to a link index.
int joint_link(const Doc& doc, const TiXmlElement* joint, const char* which, const Owner& owner,
               const RobotXml& robot) {
  const TiXmlElement* e = joint->FirstChildElement(which);
  const char* link = attribute(e, "link");
  if (link == nullptr || *link == '\0')
    doc.fail(e != nullptr ? e : joint, owner, std::string("missing <") + which + " link=\"...\"/>");
  const auto found = robot.link_index.find(link);
  if (found == robot.link_index.end()) {
    std::vector<std::string> names;
    for (const LinkXml& l : robot.links) names.push_back(l.name);
    const std::string near = did_you_mean(link, names);
    doc.fail(e, owner,
             std::string(which) + " link " + quote(link) + " is not defined" +
                 (near.empty() ? "; add <link name=\"" + std::string(link) + "\"> or correct the name" : near));
  }
  return found->second;
}

void read_joint_xml(const Doc& doc, const TiXmlElement* e, RobotXml& robot,
                    std::map<std::string, int>& joint_index) {
  JointXml joint;
  joint.name = required_name(doc, e);
  joint.xml = e;
  const Owner owner{e->Value(), joint.name};
  const auto found = joint_index.find(joint.name);
  if (found != joint_index.end())
    doc.fail(e, owner,
             "duplicate joint name (first defined at line " +
                 std::to_string(robot.joints[found->second].xml->Row()) + "); rename one");

  const char* type = attribute(e, "type");
  if (type == nullptr)
    doc.fail(e, owner,
             "missing type attribute" + misspelled_attribute(e, "type") +
                 "; add type=\"...\": revolute, continuous, prismatic, fixed, floating, planar or ball");
  const bool drake = is_tag(e, "drake:joint");
  if (drake) {
    if (std::strcmp(type, "ball") != 0)
      doc.fail(e, owner,
               "drake:joint type " + quote(type) +
                   " is not supported; only type=\"ball\" (use a standard <joint> otherwise)");
    joint.type = ir::JointType::Ball;
  } else {
    const auto t = joint_type_from(type);
    if (!t)
      doc.fail(e, owner,
               "unknown joint type " + quote(type) + joint_type_hint(type) +
                   "expected revolute, continuous, prismatic, fixed, floating, planar or ball");
    joint.type = *t;
  }

  joint.parent_link = joint_link(doc, e, "parent", owner, robot);
  joint.child_link = joint_link(doc, e, "child", owner, robot);
  if (joint.parent_link == joint.child_link)
    doc.fail(e, owner,
             "parent and child are the same link " + quote(robot.links[joint.child_link].name) +
                 "; a joint connects two different links: correct <parent> or <child>");

  check_numbers_in(doc, e, owner);
  read_pose(doc, e->FirstChildElement("origin"), owner);
  if (has_axis(joint.type)) {
    const TiXmlElement* axis_xml = e->FirstChildElement("axis");
    const auto axis = read_axis(doc, axis_xml, owner);
    if (joint.type == ir::JointType::Planar && axis) {
      const Eigen::Vector3d a = *axis;
      const bool coordinate = (std::abs(a.x() - 1.0) < 1e-9 || std::abs(a.y() - 1.0) < 1e-9 ||
                               std::abs(a.z() - 1.0) < 1e-9);
      if (!coordinate)
        doc.fail(axis_xml, owner,
                 "planar joint axis must be a coordinate axis of the joint frame "
                 "(1 0 0, 0 1 0 or 0 0 1), got " +
                     format_number(a.x()) + " " + format_number(a.y()) + " " +
                     format_number(a.z()) + "; turn the joint frame with <origin rpy> so that the plane's normal "
                     "is one of them");
    }
  }
  if (const TiXmlElement* dynamics = e->FirstChildElement("dynamics")) {
    const auto damping = read_scalar(doc, dynamics, "damping", owner);
    if (damping && *damping < 0.0)
      doc.fail(dynamics, owner,
               "negative damping " + format_number(*damping) + "; damping must be >= 0");
  }

  // One parent joint per link.
  LinkXml& child = robot.links[joint.child_link];
  if (child.parent_joint >= 0) {
    const JointXml& first = robot.joints[child.parent_joint];
    doc.fail(e, owner,
             "link " + quote(child.name) + " already has parent joint " + quote(first.name) +
                 " (line " + std::to_string(first.xml->Row()) +
                 "); a URDF link has one parent; close loops with a <loop_joint>");
  }
  child.parent_joint = static_cast<int>(robot.joints.size());
  joint_index.emplace(joint.name, static_cast<int>(robot.joints.size()));
  robot.joints.push_back(std::move(joint));
}

/// Finds the root link, rejecting cycles and forests.
int find_root(const Doc& doc, const RobotXml& robot) {
  const int nlinks = static_cast<int>(robot.links.size());
  // Cycles: walk up from every link; a walk that revisits a link is a cycle.
  // state: 0 unvisited, 1 on the current walk, 2 known to reach a root.
  std::vector<int> state(nlinks, 0);
  for (int start = 0; start < nlinks; ++start) {
    std::vector<int> walk;
    int l = start;
    while (l >= 0 && state[l] == 0) {
      state[l] = 1;
      walk.push_back(l);
      const int j = robot.links[l].parent_joint;
      l = j >= 0 ? robot.joints[j].parent_link : -1;
    }
    if (l >= 0 && state[l] == 1) {
      // The cycle is the tail of `walk` starting at l; report its joint that
      // comes last in the document.
      const auto begin = std::find(walk.begin(), walk.end(), l);
      std::string path;
      int last_joint = -1;
      for (auto it = begin; it != walk.end(); ++it) {
        path += robot.links[*it].name + " <- ";
        last_joint = std::max(last_joint, robot.links[*it].parent_joint);
      }
      path += robot.links[l].name;
      const JointXml& j = robot.joints[last_joint];
      doc.fail(j.xml, Owner{j.xml->Value(), j.name},
               "joints form a cycle (child <- parent: " + path +
                   "); a URDF must be a tree; replace one of these joints by a <loop_joint>");
    }
    for (int w : walk) state[w] = 2;
  }

  int root = -1;
  for (int l = 0; l < nlinks; ++l) {
    if (robot.links[l].parent_joint >= 0) continue;
    if (root >= 0)
      doc.fail(robot.links[l].xml, Owner{"link", robot.links[l].name},
               "second root link: no joint has it as child, and " + quote(robot.links[root].name) +
                   " (line " + std::to_string(robot.links[root].xml->Row()) +
                   ") is already the root; connect it to the tree with a joint");
    root = l;
  }
  return root;  // nlinks > 0 and no cycles: a root exists
}

RobotXml read_robot_xml(const Doc& doc, const TiXmlDocument& xml, const ReadOptions& options) {
  const TiXmlElement* root = xml.RootElement();
  if (root == nullptr)
    throw Error(doc.at(nullptr), "", "", "no <robot> element; a URDF's root element is <robot name=\"...\">");
  if (!is_tag(root, "robot")) {
    const std::string tag = root->Value();
    doc.fail(root, Owner{},
             "the root element is <" + tag + ">, expected <robot>" +
                 (tag == "loop_joints" ? "; this is a cut-joints file: give it with --cuts, and the URDF as MODEL"
                  : tag == "sdf"       ? "; this is SDFormat, which jrgen does not read: give a URDF"
                  : tag == "mujoco"    ? "; this is MJCF (MuJoCo), which jrgen does not read: give a URDF"
                                       : "; jrgen reads URDF, whose root element is <robot name=\"...\">"));
  }
  RobotXml robot;
  robot.xml = root;
  robot.name = required_name(doc, root);

  for (const TiXmlElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement())
    if (is_tag(e, "link")) read_link_xml(doc, e, robot, options);
  note_misspellings(doc, root, Owner{"robot", robot.name}, robot.notes);
  // <xacro:include>, <xacro:macro>, ...: a .xacro file given unexpanded.
  const TiXmlElement* xacro = nullptr;
  for (const TiXmlElement* e = root->FirstChildElement(); e && !xacro; e = e->NextSiblingElement())
    if (std::strncmp(e->Value(), "xacro:", 6) == 0) xacro = e;
  const std::string run_xacro = "this is a xacro file: expand it first (xacro robot.urdf.xacro > robot.urdf)";
  if (robot.links.empty())
    doc.fail(xacro != nullptr ? xacro : root, Owner{"robot", robot.name},
             xacro != nullptr ? "no <link> elements, and <" + std::string(xacro->Value()) + "> is not URDF; " + run_xacro
                              : "no <link> elements; a mechanism needs <link> elements joined by <joint> elements "
                                "(docs/urdf.md)");
  if (xacro != nullptr)
    robot.notes.push_back(Error(doc.at(xacro), "robot", robot.name,
                                "<" + std::string(xacro->Value()) + "> is not URDF and is ignored; if " + run_xacro)
                              .what());

  std::map<std::string, int> joint_index;
  for (const TiXmlElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement()) {
    if (is_tag(e, "joint") || is_tag(e, "drake:joint"))
      read_joint_xml(doc, e, robot, joint_index);
    else if (is_tag(e, "loop_joint") || is_tag(e, "drake:ball_constraint"))
      robot.cut_elements.push_back(e);
    else if (is_tag(e, "spring") || is_tag(e, "joint_spring") || is_tag(e, "joint_force"))
      robot.force_elements.push_back(e);
  }
  return robot;
}

// ---------------------------------------------------------------------------
// urdfdom
// ---------------------------------------------------------------------------

/// Silences console_bridge (urdfdom's logger) for its lifetime.
class ConsoleSilencer {
 public:
  ConsoleSilencer() : previous_(console_bridge::getLogLevel()) {
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  }
  ~ConsoleSilencer() { console_bridge::setLogLevel(previous_); }
  ConsoleSilencer(const ConsoleSilencer&) = delete;
  ConsoleSilencer& operator=(const ConsoleSilencer&) = delete;

 private:
  console_bridge::LogLevel previous_;
};

/// Replaces runs of whitespace in numeric attributes by one blank: urdfdom
/// splits vectors on ' ' only.
void normalize_numbers(TiXmlElement* e) {
  for (TiXmlAttribute* a = e->FirstAttribute(); a != nullptr; a = a->Next()) {
    if (!is_numeric_attribute(a->Name())) continue;
    std::string joined;
    for (const std::string_view token : split_whitespace(a->Value())) {
      if (!joined.empty()) joined += ' ';
      joined += token;
    }
    a->SetValue(joined.c_str());
  }
  for (TiXmlElement* c = e->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
    normalize_numbers(c);
}

/// The document handed to urdfdom: only what jrgen reads, balls as floating.
std::string urdfdom_text(const RobotXml& robot) {
  TiXmlElement out("robot");
  out.SetAttribute("name", robot.name);
  for (const LinkXml& link : robot.links) {
    TiXmlElement e("link");
    e.SetAttribute("name", link.name);
    if (const TiXmlElement* inertial = link.xml->FirstChildElement("inertial"))
      e.InsertEndChild(*inertial);
    out.InsertEndChild(e);
  }
  for (const JointXml& joint : robot.joints) {
    TiXmlElement e("joint");
    e.SetAttribute("name", joint.name);
    e.SetAttribute(
        "type", joint.type == ir::JointType::Ball ? "floating" : ir::joint_type_name(joint.type));
    for (const char* tag : {"parent", "child", "origin"})
      if (const TiXmlElement* c = joint.xml->FirstChildElement(tag)) e.InsertEndChild(*c);
    const TiXmlElement* axis = joint.xml->FirstChildElement("axis");
    if (has_axis(joint.type) && attribute(axis, "xyz") != nullptr) e.InsertEndChild(*axis);
    const TiXmlElement* dynamics = joint.xml->FirstChildElement("dynamics");
    if (attribute(dynamics, "damping") != nullptr || attribute(dynamics, "friction") != nullptr)
      e.InsertEndChild(*dynamics);
    if (joint.type == ir::JointType::Revolute || joint.type == ir::JointType::Prismatic) {
      // urdfdom insists on limits here; jrgen does not use them.
      TiXmlElement limit("limit");
      limit.SetAttribute("effort", "0");
      limit.SetAttribute("velocity", "0");
      e.InsertEndChild(limit);
    }
    out.InsertEndChild(e);
  }
  normalize_numbers(&out);
  TiXmlPrinter printer;
  out.Accept(&printer);
  return printer.CStr();
}

Eigen::Matrix3d rotation_from(const ::urdf::Rotation& q) {
  return Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
}

ir::Pose pose_from(const ::urdf::Pose& pose) {
  ir::Pose out;
  out.p = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  out.R = rotation_from(pose.rotation);
  return out;
}

// ---------------------------------------------------------------------------
// Cut joints
// ---------------------------------------------------------------------------

std::optional<ir::CutType> cut_type_from(std::string_view s) {
  if (s == "spherical") return ir::CutType::Spherical;
  if (s == "revolute") return ir::CutType::Revolute;
  if (s == "prismatic") return ir::CutType::Prismatic;
  if (s == "cylindrical") return ir::CutType::Cylindrical;
  if (s == "universal") return ir::CutType::Universal;
  if (s == "fixed") return ir::CutType::Fixed;
  if (s == "distance") return ir::CutType::Distance;
  return std::nullopt;
}

/// Names a cut joint must not reuse: tree joints and cuts read so far.
struct CutNames {
  std::map<std::string, std::string> taken;  ///< name -> "joint at line N" etc.
};

void claim_cut_name(const Doc& doc, const TiXmlElement* e, const Owner& owner, CutNames& names,
                    const std::string& what) {
  const auto [it, inserted] = names.taken.emplace(owner.name, what);
  if (!inserted) doc.fail(e, owner, "name already used by " + it->second + "; rename one");
}

int cut_link(const Doc& doc, const TiXmlElement* e, const char* which, const char* attr,
             const Owner& owner, const ir::Robot& robot) {
  const TiXmlElement* c = e->FirstChildElement(which);
  const char* link = attribute(c, attr);
  if (link == nullptr || *link == '\0')
    doc.fail(c != nullptr ? c : e, owner,
             std::string("missing <") + which + " " + attr + "=\"...\"/>");
  const int index = robot.find_link(link);
  if (index < 0) {
    std::vector<std::string> names;
    for (const ir::Link& l : robot.links) names.push_back(l.name);
    const std::string near = did_you_mean(link, names);
    doc.fail(c, owner,
             std::string("<") + which + ">: link " + quote(link) + " is not defined in robot " + quote(robot.name) +
                 (near.empty() ? "; name one of its <link> elements" : near));
  }
  return index;
}

ir::CutJoint read_loop_joint(const Doc& doc, const TiXmlElement* e, const ir::Robot& robot,
                             CutNames& names) {
  ir::CutJoint cut;
  cut.name = required_name(doc, e);
  cut.where = doc.at(e);
  const Owner owner{"loop_joint", cut.name};
  claim_cut_name(doc, e, owner, names,
                 "the loop joint at " + doc.file + ":" + std::to_string(e->Row()));

  const char* type = attribute(e, "type");
  if (type == nullptr)
    doc.fail(e, owner,
             "missing type attribute; add type=\"...\": spherical, revolute, prismatic, cylindrical, universal, "
             "fixed or distance");
  const auto t = cut_type_from(type);
  if (!t) {
    const std::string given = type;
    const std::string meant = given == "ball" || given == "socket" ? "spherical"
                              : given == "continuous" || given == "hinge" ? "revolute"
                              : given == "slider" ? "prismatic"
                              : closest_match(given, {"spherical", "revolute", "prismatic", "cylindrical",
                                                      "universal", "fixed", "distance"});
    doc.fail(e, owner,
             "unknown loop joint type " + quote(type) + (meant.empty() ? "" : " (did you mean " + quote(meant) + "?)") +
                 "; expected spherical, revolute, prismatic, cylindrical, universal, fixed or "
                 "distance");
  }
  cut.type = *t;

  check_numbers_in(doc, e, owner);
  cut.link_k = cut_link(doc, e, "parent", "link", owner, robot);
  cut.link_l = cut_link(doc, e, "child", "link", owner, robot);
  if (cut.link_k == cut.link_l)
    doc.fail(e, owner,
             "parent and child are the same link " + quote(robot.links[cut.link_k].name) +
                 "; a loop joint connects two different links: correct <parent> or <child>");
  cut.frame_k = read_pose(doc, e->FirstChildElement("origin"), owner);
  cut.frame_l = read_pose(doc, e->FirstChildElement("child_origin"), owner);
  if (const auto axis = read_axis(doc, e->FirstChildElement("axis"), owner)) cut.axis = *axis;
  if (const auto axis = read_axis(doc, e->FirstChildElement("child_axis"), owner))
    cut.child_axis = *axis;
  if (const TiXmlElement* d = e->FirstChildElement("distance")) {
    const auto value = read_scalar(doc, d, "value", owner);
    if (!value) doc.fail(d, owner, "<distance> has no value attribute; write <distance value=\"...\"/> (metres)");
    if (!(*value > 0.0))
      doc.fail(d, owner,
               "distance " + format_number(*value) +
                   " must be positive; use a spherical loop joint for coincident points");
    cut.distance = *value;
    cut.distance_given = true;
  }
  return cut;
}

/// Drake's <drake:ball_constraint>: a spherical cut between body_A (k) and
/// body_B (l) at p_AP on A and p_BQ on B.  Named by its name attribute if
/// any, else "ball_constraint_<n>", n counting these elements from 1.
ir::CutJoint read_ball_constraint(const Doc& doc, const TiXmlElement* e, int number,
                                  const ir::Robot& robot, CutNames& names) {
  ir::CutJoint cut;
  const char* name = attribute(e, "name");
  cut.name = (name != nullptr && *name != '\0') ? std::string(name)
                                                : "ball_constraint_" + std::to_string(number);
  cut.where = doc.at(e);
  cut.type = ir::CutType::Spherical;
  const Owner owner{"drake:ball_constraint", cut.name};
  claim_cut_name(doc, e, owner, names,
                 "the loop joint at " + doc.file + ":" + std::to_string(e->Row()));
  check_numbers_in(doc, e, owner);
  cut.link_k = cut_link(doc, e, "drake:ball_constraint_body_A", "name", owner, robot);
  cut.link_l = cut_link(doc, e, "drake:ball_constraint_body_B", "name", owner, robot);
  if (cut.link_k == cut.link_l)
    doc.fail(e, owner,
             "body_A and body_B are the same link " + quote(robot.links[cut.link_k].name));
  for (const char* tag : {"drake:ball_constraint_p_AP", "drake:ball_constraint_p_BQ"}) {
    const TiXmlElement* p = e->FirstChildElement(tag);
    if (attribute(p, "value") == nullptr)
      doc.fail(p != nullptr ? p : e, owner, std::string("missing <") + tag + " value=\"x y z\"/>");
  }
  cut.frame_k.p = read_vec3(doc, e->FirstChildElement("drake:ball_constraint_p_AP"), "value", owner,
                            Eigen::Vector3d::Zero());
  cut.frame_l.p = read_vec3(doc, e->FirstChildElement("drake:ball_constraint_p_BQ"), "value", owner,
                            Eigen::Vector3d::Zero());
  return cut;
}

// ---------------------------------------------------------------------------
// Force elements and mimic rows (docs/interface.md section 2b)
// ---------------------------------------------------------------------------

int find_joint(const ir::Robot& robot, const std::string& name) {
  for (std::size_t j = 0; j < robot.joints.size(); ++j)
    if (robot.joints[j].name == name) return static_cast<int>(j);
  return -1;
}

bool one_dof(ir::JointType type) {
  return type == ir::JointType::Revolute || type == ir::JointType::Continuous ||
         type == ir::JointType::Prismatic;
}

/// Attribute `attr` of `e` as one finite number >= 0; `fallback` when absent
/// (nullopt: the attribute is required).
double non_negative(const Doc& doc, const TiXmlElement* e, const char* attr, const Owner& owner,
                    std::optional<double> fallback) {
  const auto value = read_scalar(doc, e, attr, owner);
  if (!value && !fallback)
    doc.fail(e, owner, std::string("missing ") + attr + " attribute; give " + attr + "=\"...\" (>= 0, SI units)");
  const double x = value ? *value : *fallback;
  if (x < 0.0)
    doc.fail(e, owner, std::string("negative ") + attr + " " + format_number(x) + "; " + attr + " must be >= 0");
  return x;
}

/// The joint named by attribute `attr` of `e`: defined, and with one dof.
int one_dof_joint(const Doc& doc, const TiXmlElement* e, const char* attr, const Owner& owner,
                  const ir::Robot& robot) {
  const char* name = attribute(e, attr);
  if (name == nullptr || *name == '\0')
    doc.fail(e, owner,
             std::string("missing ") + attr + " attribute; name the revolute, continuous or prismatic joint");
  const int j = find_joint(robot, name);
  if (j < 0) {
    std::vector<std::string> names;
    for (const ir::Joint& joint : robot.joints) names.push_back(joint.name);
    const std::string near = did_you_mean(name, names);
    doc.fail(e, owner,
             "joint " + quote(name) + " is not defined in robot " + quote(robot.name) +
                 (near.empty() ? "; name one of its <joint> elements" : near));
  }
  if (!one_dof(robot.joints[j].type))
    doc.fail(e, owner,
             "joint " + quote(name) + " is " + ir::joint_type_name(robot.joints[j].type) + "; <" + e->Value() +
                 "> acts on a revolute, continuous or prismatic joint only");
  return j;
}

ir::Spring read_spring(const Doc& doc, const TiXmlElement* e, const ir::Robot& robot) {
  ir::Spring spring;
  spring.name = required_name(doc, e);
  spring.where = doc.at(e);
  const Owner owner{"spring", spring.name};
  for (const ir::Spring& other : robot.springs)
    if (other.name == spring.name)
      doc.fail(e, owner,
               "duplicate spring name (first defined at line " + std::to_string(other.where.line) + "); rename one");
  spring.stiffness = non_negative(doc, e, "stiffness", owner, std::nullopt);
  spring.damping = non_negative(doc, e, "damping", owner, 0.0);
  if (attribute(e, "rest_length") != nullptr) {
    spring.rest_length = non_negative(doc, e, "rest_length", owner, std::nullopt);
    spring.rest_given = true;
  }
  spring.link_k = cut_link(doc, e, "parent", "link", owner, robot);
  spring.link_l = cut_link(doc, e, "child", "link", owner, robot);
  if (spring.link_k == spring.link_l)
    doc.fail(e, owner,
             "both points are on link " + quote(robot.links[spring.link_k].name) +
                 "; a spring joins two different links (one may be the fixed root)");
  spring.p_k = read_vec3(doc, e->FirstChildElement("parent"), "xyz", owner, Eigen::Vector3d::Zero());
  spring.p_l = read_vec3(doc, e->FirstChildElement("child"), "xyz", owner, Eigen::Vector3d::Zero());
  return spring;
}

ir::JointSpring read_joint_spring(const Doc& doc, const TiXmlElement* e, const ir::Robot& robot) {
  const char* joint = attribute(e, "joint");
  const Owner owner{"joint_spring", joint != nullptr ? joint : ""};
  ir::JointSpring spring;
  spring.joint = one_dof_joint(doc, e, "joint", owner, robot);
  spring.where = doc.at(e);
  for (const ir::JointSpring& other : robot.joint_springs)
    if (other.joint == spring.joint)
      doc.fail(e, owner,
               "a second <joint_spring> on this joint (first at line " + std::to_string(other.where.line) +
                   "); merge them into one");
  spring.stiffness = non_negative(doc, e, "stiffness", owner, std::nullopt);
  spring.damping = non_negative(doc, e, "damping", owner, 0.0);
  const auto rest = read_scalar(doc, e, "rest", owner);
  spring.rest = rest ? *rest : 0.0;
  return spring;
}

ir::JointForce read_joint_force(const Doc& doc, const TiXmlElement* e, const ir::Robot& robot) {
  const char* joint = attribute(e, "joint");
  const Owner owner{"joint_force", joint != nullptr ? joint : ""};
  ir::JointForce force;
  force.joint = one_dof_joint(doc, e, "joint", owner, robot);
  force.where = doc.at(e);
  for (const ir::JointForce& other : robot.joint_forces)
    if (other.joint == force.joint)
      doc.fail(e, owner,
               "a second <joint_force> on this joint (first at line " + std::to_string(other.where.line) +
                   "); add their values into one");
  const auto value = read_scalar(doc, e, "value", owner);
  if (!value) doc.fail(e, owner, "missing value attribute; give value=\"...\" (N m or N)");
  force.value = *value;
  return force;
}

void read_force_elements(const Doc& doc, const RobotXml& xml, ir::Robot& robot) {
  for (const TiXmlElement* e : xml.force_elements) {
    if (is_tag(e, "spring")) robot.springs.push_back(read_spring(doc, e, robot));
    else if (is_tag(e, "joint_spring")) robot.joint_springs.push_back(read_joint_spring(doc, e, robot));
    else robot.joint_forces.push_back(read_joint_force(doc, e, robot));
  }
}

/// URDF <mimic joint multiplier offset> of tree joint `j` (nullopt when it has
/// none): the row q_j - multiplier q_leader - offset = 0, named after joint j.
std::optional<ir::CutJoint> read_mimic(const Doc& doc, const TiXmlElement* joint_xml, int j,
                                       const ir::Robot& robot) {
  const TiXmlElement* e = joint_xml->FirstChildElement("mimic");
  if (e == nullptr) return std::nullopt;
  const ir::Joint& joint = robot.joints[j];
  const Owner owner{joint_xml->Value(), joint.name};
  if (!one_dof(joint.type))
    doc.fail(e, owner,
             std::string("<mimic> on a ") + ir::joint_type_name(joint.type) +
                 " joint; only revolute, continuous and prismatic joints can mimic another");
  ir::CutJoint row;
  row.name = joint.name;
  row.type = ir::CutType::Mimic;
  row.where = doc.at(e);
  row.mimic_joint = j;
  row.mimic_leader = one_dof_joint(doc, e, "joint", owner, robot);
  if (row.mimic_leader == j) doc.fail(e, owner, "<mimic> names its own joint; name the joint it follows");
  row.multiplier = read_scalar(doc, e, "multiplier", owner).value_or(1.0);
  row.offset = read_scalar(doc, e, "offset", owner).value_or(0.0);
  row.link_k = robot.joints[row.mimic_leader].child_link;
  row.link_l = joint.child_link;
  return row;
}

CutNames names_in_use(const ir::Robot& robot) {
  CutNames names;
  for (const ir::Joint& j : robot.joints)
    names.taken.emplace(j.name,
                        "the tree joint at " + j.where.file + ":" + std::to_string(j.where.line));
  for (const ir::CutJoint& c : robot.cuts)
    names.taken.emplace(c.name,
                        "the loop joint at " + c.where.file + ":" + std::to_string(c.where.line));
  return names;
}

}  // namespace

// ---------------------------------------------------------------------------
// Public API
// ---------------------------------------------------------------------------

ir::Robot read_robot(const std::string& urdf_path, const ReadOptions& options) {
  return read_robot_string(read_file(urdf_path), urdf_path, options);
}

ir::Robot read_robot_string(const std::string& xml, const std::string& display_name,
                            const ReadOptions& options) {
  const Doc doc{display_name};
  TiXmlDocument document;
  parse_xml(doc, xml, document);
  const RobotXml robot_xml = read_robot_xml(doc, document, options);
  const int root = find_root(doc, robot_xml);

  // Standard content through urdfdom.
  ::urdf::ModelInterfaceSharedPtr model;
  {
    const ConsoleSilencer silence;
    try {
      model = ::urdf::parseURDF(urdfdom_text(robot_xml));
    } catch (const std::exception&) {
      model.reset();
    }
  }
  const Error urdfdom_failed(ir::SourceLocation{display_name, 0}, "", "",
                             "urdfdom could not parse the model");
  if (!model) throw urdfdom_failed;

  ir::Robot robot;
  robot.name = robot_xml.name;
  robot.source_file = display_name;
  robot.root_link = root;
  robot.notes = robot_xml.notes;

  // Links, document order.
  for (const LinkXml& link_xml : robot_xml.links) {
    const auto link = model->getLink(link_xml.name);
    if (!link) throw urdfdom_failed;
    ir::Link out;
    out.name = link_xml.name;
    out.where = doc.at(link_xml.xml);
    if (link->inertial) {
      const ::urdf::Inertial& in = *link->inertial;
      const ir::Pose frame = pose_from(in.origin);  // inertia frame in the link frame
      Eigen::Matrix3d I;
      I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      out.inertial.mass = in.mass;
      out.inertial.com = frame.p;
      out.inertial.I_com = frame.R * I * frame.R.transpose();
      // Remove the rounding asymmetry of the product.  Halves first: the
      // same bits as 0.5 (A + A^T), without overflowing near DBL_MAX.
      out.inertial.I_com = (0.5 * out.inertial.I_com + 0.5 * out.inertial.I_com.transpose()).eval();
    }
    robot.links.push_back(std::move(out));
  }

  // Joints, user order: depth-first from the root, children in document
  // order of their joint elements (explicit stack: chains may be long).
  std::vector<std::vector<int>> child_joints(robot_xml.links.size());
  for (std::size_t j = 0; j < robot_xml.joints.size(); ++j)
    child_joints[robot_xml.joints[j].parent_link].push_back(static_cast<int>(j));
  std::vector<int> stack(child_joints[root].rbegin(), child_joints[root].rend());
  std::vector<const TiXmlElement*> joint_xml_of;  // per ir joint
  while (!stack.empty()) {
    const JointXml& joint_xml = robot_xml.joints[stack.back()];
    joint_xml_of.push_back(joint_xml.xml);
    stack.pop_back();
    const auto joint = model->getJoint(joint_xml.name);
    if (!joint) throw urdfdom_failed;
    ir::Joint out;
    out.name = joint_xml.name;
    out.type = joint_xml.type;
    out.parent_link = joint_xml.parent_link;
    out.child_link = joint_xml.child_link;
    out.origin = pose_from(joint->parent_to_joint_origin_transform);
    if (has_axis(joint_xml.type) && joint_xml.xml->FirstChildElement("axis") != nullptr &&
        attribute(joint_xml.xml->FirstChildElement("axis"), "xyz") != nullptr) {
      const Eigen::Vector3d axis(joint->axis.x, joint->axis.y, joint->axis.z);
      out.axis = axis.normalized();
    }
    if (joint->dynamics) out.damping = joint->dynamics->damping;
    out.where = doc.at(joint_xml.xml);
    robot.joints.push_back(std::move(out));
    const auto& next = child_joints[joint_xml.child_link];
    stack.insert(stack.end(), next.rbegin(), next.rend());
  }

  // Cut joints written in the URDF, document order, then the mimic rows.
  CutNames names = names_in_use(robot);
  int ball_constraints = 0;
  for (const TiXmlElement* e : robot_xml.cut_elements) {
    if (is_tag(e, "loop_joint"))
      robot.cuts.push_back(read_loop_joint(doc, e, robot, names));
    else
      robot.cuts.push_back(read_ball_constraint(doc, e, ++ball_constraints, robot, names));
  }
  for (std::size_t j = 0; j < robot.joints.size(); ++j)
    if (auto row = read_mimic(doc, joint_xml_of[j], static_cast<int>(j), robot)) robot.cuts.push_back(*row);
  read_force_elements(doc, robot_xml, robot);
  return robot;
}

void read_cuts(const std::string& cuts_path, ir::Robot& robot) {
  read_cuts_string(read_file(cuts_path), cuts_path, robot);
}

void read_cuts_string(const std::string& xml, const std::string& display_name, ir::Robot& robot) {
  const Doc doc{display_name};
  TiXmlDocument document;
  parse_xml(doc, xml, document);
  const TiXmlElement* root = document.RootElement();
  if (root == nullptr)
    throw Error(doc.at(nullptr), "", "", "no <loop_joints> element; a cuts file's root element is <loop_joints>");
  if (!is_tag(root, "loop_joints"))
    doc.fail(root, Owner{},
             "the root element is <" + std::string(root->Value()) + ">, expected <loop_joints>" +
                 (is_tag(root, "robot") ? "; this is a URDF: give it as MODEL.urdf; --cuts takes a file of "
                                          "<loop_joint> elements inside <loop_joints>"
                                        : "; a cuts file holds <loop_joint> elements inside <loop_joints> "
                                          "(docs/urdf.md)"));
  CutNames names = names_in_use(robot);
  std::vector<ir::CutJoint> cuts;
  for (const TiXmlElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement()) {
    if (!is_tag(e, "loop_joint"))
      doc.fail(e, Owner{},
               "unexpected element <" + std::string(e->Value()) + "> in <loop_joints>; expected <loop_joint>" +
                   (is_tag(e, "joint") || is_tag(e, "link")
                        ? std::string(" (links and tree joints belong in the URDF)")
                        : std::string(" (a cuts file holds only <loop_joint> elements)")));
    cuts.push_back(read_loop_joint(doc, e, robot, names));
    note_misspellings(doc, e, Owner{"loop_joint", cuts.back().name}, robot.notes);
  }
  robot.cuts.insert(robot.cuts.end(), cuts.begin(), cuts.end());
}

}  // namespace jrgen::urdf
