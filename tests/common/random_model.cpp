// Seeded random URDF generators (see random_model.hpp).
#include "random_model.hpp"

#include <tinyxml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <locale>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace jrgen::testing {
namespace {

constexpr double kPi = 3.14159265358979323846;

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<std::array<double, 3>, 3>;

// Uniform deviates from the raw 64-bit output of mt19937_64 (fixed by the
// standard); the std:: distributions are implementation-defined, so they are
// not used.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int index(int n) {  // uniform in [0, n)
    int k = static_cast<int>(uniform() * n);
    return k < n ? k : n - 1;
  }
  double log_uniform(double lo, double hi) {
    return lo == hi ? lo : std::exp(uniform(std::log(lo), std::log(hi)));
  }
  Vec3 unit_vector() {
    const double z = uniform(-1.0, 1.0);
    const double phi = uniform(0.0, 2.0 * kPi);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
  }
  // Uniformly random rotation (Shoemake's subgroup algorithm).
  Mat3 rotation() {
    const double u1 = uniform(), u2 = uniform(0.0, 2.0 * kPi), u3 = uniform(0.0, 2.0 * kPi);
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    const double w = a * std::sin(u2), x = a * std::cos(u2), y = b * std::sin(u3), z = b * std::cos(u3);
    Mat3 R;
    R[0] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)};
    R[1] = {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)};
    R[2] = {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    return R;
  }

 private:
  std::mt19937_64 engine_;
};

std::string num(double v) {
  std::ostringstream os;
  os.imbue(std::locale::classic());
  os.precision(15);
  if (v == 0.0) v = 0.0;  // no "-0"
  os << v;
  return os.str();
}

std::string vec(const Vec3& v) { return num(v[0]) + " " + num(v[1]) + " " + num(v[2]); }

// <link> with a random valid inertial.
std::string random_link(Rng& rng, const std::string& name, double mass) {
  const Vec3 d = {rng.uniform(0.002, 0.05), rng.uniform(0.002, 0.05), rng.uniform(0.002, 0.05)};
  const Vec3 principal = {mass * (d[1] + d[2]), mass * (d[0] + d[2]), mass * (d[0] + d[1])};
  const Mat3 R = rng.rotation();
  Mat3 I{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) I[i][j] += R[i][k] * principal[k] * R[j][k];
  const Vec3 com = {rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)};
  std::string s;
  s += "  <link name=\"" + name + "\">\n";
  s += "    <inertial>\n";
  s += "      <origin xyz=\"" + vec(com) + "\" rpy=\"0 0 0\"/>\n";
  s += "      <mass value=\"" + num(mass) + "\"/>\n";
  s += "      <inertia ixx=\"" + num(I[0][0]) + "\" ixy=\"" + num(I[0][1]) + "\" ixz=\"" + num(I[0][2]) +
       "\" iyy=\"" + num(I[1][1]) + "\" iyz=\"" + num(I[1][2]) + "\" izz=\"" + num(I[2][2]) + "\"/>\n";
  s += "    </inertial>\n";
  s += "  </link>\n";
  return s;
}

enum class Type { Revolute, Continuous, Prismatic, Ball, Planar, Fixed, Floating };

const char* type_name(Type t) {
  switch (t) {
    case Type::Revolute: return "revolute";
    case Type::Continuous: return "continuous";
    case Type::Prismatic: return "prismatic";
    case Type::Ball: return "ball";
    case Type::Planar: return "planar";
    case Type::Fixed: return "fixed";
    case Type::Floating: return "floating";
  }
  return "";
}

// <joint> with a random origin, axis (where the type has one) and damping.
std::string random_joint(Rng& rng, const std::string& name, Type type, const std::string& parent,
                         const std::string& child, bool damping) {
  const Vec3 xyz = {rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5)};
  const Vec3 rpy = {rng.uniform(-kPi, kPi), rng.uniform(-kPi, kPi), rng.uniform(-kPi, kPi)};
  std::string s;
  s += "  <joint name=\"" + name + "\" type=\"" + type_name(type) + "\">\n";
  s += "    <parent link=\"" + parent + "\"/>\n";
  s += "    <child link=\"" + child + "\"/>\n";
  s += "    <origin xyz=\"" + vec(xyz) + "\" rpy=\"" + vec(rpy) + "\"/>\n";
  switch (type) {
    case Type::Revolute:
    case Type::Continuous:
    case Type::Prismatic:
      s += "    <axis xyz=\"" + vec(rng.unit_vector()) + "\"/>\n";
      break;
    case Type::Planar: {
      Vec3 n = {0, 0, 0};
      n[rng.index(3)] = 1.0;
      s += "    <axis xyz=\"" + vec(n) + "\"/>\n";
      break;
    }
    default:
      break;
  }
  if (type == Type::Revolute)
    s += "    <limit lower=\"-3.14159\" upper=\"3.14159\" effort=\"100\" velocity=\"10\"/>\n";
  else if (type == Type::Prismatic)
    s += "    <limit lower=\"-1\" upper=\"1\" effort=\"100\" velocity=\"10\"/>\n";
  if (damping && type != Type::Fixed && type != Type::Floating)
    s += "    <dynamics damping=\"" + num(rng.log_uniform(0.01, 1.0)) + "\"/>\n";
  s += "  </joint>\n";
  return s;
}

std::string header(const std::string& robot, const std::string& what) {
  return "<?xml version=\"1.0\"?>\n<!-- " + what + " (jrgen::testing, generated) -->\n<robot name=\"" +
         robot + "\">\n  <link name=\"world\"/>\n";
}

}  // namespace

std::string random_tree_urdf(const RandomTreeOptions& o) {
  if (o.num_bodies < 1) throw std::invalid_argument("random_tree_urdf: num_bodies must be >= 1");
  if (o.max_depth < 0) throw std::invalid_argument("random_tree_urdf: max_depth must be >= 0");
  if (!(o.mass_ratio >= 1.0)) throw std::invalid_argument("random_tree_urdf: mass_ratio must be >= 1");
  if (o.floating_base && o.max_depth == 1 && o.num_bodies > 1)
    throw std::invalid_argument("random_tree_urdf: a floating base with max_depth 1 allows one body only");
  if (o.mechanism_bodies < 0) throw std::invalid_argument("random_tree_urdf: mechanism_bodies must be >= 0");
  if (o.mechanism_bodies > 0 && o.floating_base)
    throw std::invalid_argument("random_tree_urdf: mechanism_bodies and floating_base do not go together");
  if (o.mechanism_bodies > 1 && o.max_depth == 1)
    throw std::invalid_argument("random_tree_urdf: a mechanism of several bodies needs max_depth >= 2");
  const std::array<std::pair<Type, double>, 6> weights = {{{Type::Revolute, o.p_revolute},
                                                           {Type::Continuous, o.p_continuous},
                                                           {Type::Prismatic, o.p_prismatic},
                                                           {Type::Ball, o.p_ball},
                                                           {Type::Planar, o.p_planar},
                                                           {Type::Fixed, o.p_fixed}}};
  double total = 0.0;
  for (const auto& [t, w] : weights) {
    if (!(w >= 0.0)) throw std::invalid_argument("random_tree_urdf: negative joint type weight");
    total += w;
  }
  if (!(total > 0.0)) throw std::invalid_argument("random_tree_urdf: all joint type weights are zero");

  Rng rng(o.seed);
  const std::string robot = "random_" + std::to_string(o.seed) + "_" + std::to_string(o.num_bodies);
  std::string out = header(robot, "random tree, seed " + std::to_string(o.seed) + ", " +
                                      std::to_string(o.num_bodies) + " bodies, max depth " +
                                      std::to_string(o.max_depth) + (o.floating_base ? ", floating base" : "") +
                                      (o.mechanism_bodies > 0
                                           ? ", mechanisms of " + std::to_string(o.mechanism_bodies) + " bodies"
                                           : std::string()));
  std::vector<int> depth = {0};  // index 0: world
  std::vector<std::string> names = {"world"};
  std::vector<int> candidates;
  for (int i = 1; i <= o.num_bodies; ++i) {
    int parent = 0;
    Type type = Type::Floating;
    if (!(o.floating_base && i == 1)) {
      candidates.clear();
      if (o.mechanism_bodies > 0) {
        // A scene: the first body of each group starts a new mechanism on
        // the world; the others attach within their own group.
        const int first = 1 + (i - 1) / o.mechanism_bodies * o.mechanism_bodies;
        if (i == first) candidates.push_back(0);
        for (int k = first; k < i; ++k)
          if (o.max_depth == 0 || depth[k] < o.max_depth) candidates.push_back(k);
      } else {
        for (int k = (o.floating_base ? 1 : 0); k < i; ++k)
          if (o.max_depth == 0 || depth[k] < o.max_depth) candidates.push_back(k);
      }
      parent = candidates[rng.index(static_cast<int>(candidates.size()))];
      double r = rng.uniform() * total;
      for (const auto& [t, w] : weights)  // fallback against rounding: last type with weight
        if (w > 0.0) type = t;
      for (const auto& [t, w] : weights) {
        if (w > 0.0 && r < w) {
          type = t;
          break;
        }
        r -= w;
      }
    }
    const std::string name = "body_" + std::to_string(i);
    out += random_joint(rng, "joint_" + std::to_string(i), type, names[parent], name, o.damping);
    out += random_link(rng, name, rng.log_uniform(1.0, o.mass_ratio));
    names.push_back(name);
    depth.push_back(depth[parent] + 1);
  }
  out += "</robot>\n";
  return out;
}

std::string chain_urdf(int num_joints, std::uint64_t seed) {
  if (num_joints < 1) throw std::invalid_argument("chain_urdf: num_joints must be >= 1");
  Rng rng(seed);
  const std::string robot = "chain_" + std::to_string(seed) + "_" + std::to_string(num_joints);
  std::string out = header(robot, "serial revolute chain, seed " + std::to_string(seed) + ", " +
                                      std::to_string(num_joints) + " joints");
  std::string parent = "world";
  for (int i = 1; i <= num_joints; ++i) {
    const std::string name = "link_" + std::to_string(i);
    out += random_joint(rng, "joint_" + std::to_string(i), Type::Revolute, parent, name, true);
    out += random_link(rng, name, rng.log_uniform(1.0, 2.0));
    parent = name;
  }
  out += "</robot>\n";
  return out;
}

std::string add_floating_base(const std::string& urdf_text) {
  TiXmlDocument doc;
  doc.Parse(urdf_text.c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (doc.Error())
    throw std::invalid_argument(std::string("add_floating_base: XML error: ") + doc.ErrorDesc() + " (line " +
                                std::to_string(doc.ErrorRow()) + ")");
  TiXmlElement* robot = doc.RootElement();
  if (!robot || robot->ValueStr() != "robot") throw std::invalid_argument("add_floating_base: no <robot> root element");

  std::vector<std::string> links;
  std::set<std::string> children;
  for (TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const char* n = e->Attribute("name");
    if (!n) throw std::invalid_argument("add_floating_base: <link> without a name");
    if (std::string(n) == "jr_world") throw std::invalid_argument("add_floating_base: link jr_world exists already");
    links.emplace_back(n);
  }
  for (TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const char* n = e->Attribute("name");
    if (n && std::string(n) == "jr_floating_base")
      throw std::invalid_argument("add_floating_base: joint jr_floating_base exists already");
    const TiXmlElement* c = e->FirstChildElement("child");
    const char* cl = c ? c->Attribute("link") : nullptr;
    if (!cl) throw std::invalid_argument("add_floating_base: <joint> without <child link>");
    children.insert(cl);
  }
  std::string root;
  int roots = 0;
  for (const auto& l : links)
    if (!children.count(l)) {
      root = l;
      ++roots;
    }
  if (roots != 1)
    throw std::invalid_argument("add_floating_base: expected exactly one root link, found " + std::to_string(roots));

  TiXmlElement link("link");
  link.SetAttribute("name", "jr_world");
  TiXmlElement joint("joint");
  joint.SetAttribute("name", "jr_floating_base");
  joint.SetAttribute("type", "floating");
  TiXmlElement parent("parent"), child("child"), origin("origin");
  parent.SetAttribute("link", "jr_world");
  child.SetAttribute("link", root);
  origin.SetAttribute("xyz", "0 0 0");
  origin.SetAttribute("rpy", "0 0 0");
  joint.InsertEndChild(parent);
  joint.InsertEndChild(child);
  joint.InsertEndChild(origin);

  TiXmlNode* first = robot->FirstChild();
  if (first) {
    robot->InsertBeforeChild(first, link);
    robot->InsertBeforeChild(first, joint);
  } else {
    robot->InsertEndChild(link);
    robot->InsertEndChild(joint);
  }
  TiXmlPrinter printer;
  printer.SetIndent("  ");
  doc.Accept(&printer);
  return printer.Str();
}

}  // namespace jrgen::testing

namespace jrgen::testing {

namespace {

std::string fixed_number(double x) {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s.precision(17);
  s << x;
  return s.str();
}

TiXmlDocument parse_or_throw(const std::string& text, const char* what) {
  TiXmlDocument doc;
  doc.Parse(text.c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (doc.Error())
    throw std::invalid_argument(std::string("vehicle_train: ") + what + ": XML error: " + doc.ErrorDesc() +
                                " (line " + std::to_string(doc.ErrorRow()) + ")");
  return doc;
}

// Prefixes the `attribute` of every `child` element of e (e.g. <parent link>).
void prefix_child(TiXmlElement* e, const char* child, const char* attribute, const std::string& prefix,
                  const std::string& keep) {
  for (TiXmlElement* c = e->FirstChildElement(child); c; c = c->NextSiblingElement(child))
    if (const char* v = c->Attribute(attribute))
      if (v != keep) c->SetAttribute(attribute, prefix + v);
}

}  // namespace

ModelWithCuts vehicle_train(int vehicles, const std::string& vehicle_urdf, const std::string& vehicle_cuts,
                            double spacing) {
  if (vehicles < 1) throw std::invalid_argument("vehicle_train: needs at least one vehicle");
  TiXmlDocument urdf = parse_or_throw(vehicle_urdf, "vehicle URDF");
  TiXmlDocument cuts = parse_or_throw(vehicle_cuts, "vehicle cuts");
  const TiXmlElement* robot = urdf.RootElement();
  if (!robot || robot->ValueStr() != "robot") throw std::invalid_argument("vehicle_train: no <robot> root element");
  const TiXmlElement* loops = cuts.RootElement();
  if (!loops || loops->ValueStr() != "loop_joints")
    throw std::invalid_argument("vehicle_train: the cuts file has no <loop_joints> root element");

  // The world link stays shared; find the floating joint hanging from it.
  const std::string world = "world";
  std::string root_link;
  for (const TiXmlElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const TiXmlElement* p = j->FirstChildElement("parent");
    if (p && p->Attribute("link") && world == p->Attribute("link")) {
      const char* type = j->Attribute("type");
      const TiXmlElement* c = j->FirstChildElement("child");
      if (!type || std::string(type) != "floating" || !c || !c->Attribute("link") || !root_link.empty())
        throw std::invalid_argument("vehicle_train: the world link must carry exactly one floating joint");
      root_link = c->Attribute("link");
    }
  }
  if (root_link.empty()) throw std::invalid_argument("vehicle_train: no floating joint from the world link");

  TiXmlDocument out_urdf;
  out_urdf.InsertEndChild(TiXmlDeclaration("1.0", "", ""));
  TiXmlElement out_robot("robot");
  out_robot.SetAttribute("name", "train_" + std::to_string(vehicles));
  TiXmlElement world_link("link");
  world_link.SetAttribute("name", world);
  out_robot.InsertEndChild(world_link);
  TiXmlElement out_loops("loop_joints");

  for (int i = 0; i < vehicles; ++i) {
    const std::string prefix = "v" + std::to_string(i) + "_";
    for (const TiXmlElement* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
      if (e->ValueStr() == "link" && e->Attribute("name") && world == e->Attribute("name")) continue;
      TiXmlElement copy(*e);
      if (const char* n = copy.Attribute("name")) copy.SetAttribute("name", prefix + n);
      if (copy.ValueStr() == "joint") {
        prefix_child(&copy, "parent", "link", prefix, world);
        prefix_child(&copy, "child", "link", prefix, "");
        const TiXmlElement* p = copy.FirstChildElement("parent");
        if (p && world == p->Attribute("link")) {  // the floating joint: move the vehicle back
          TiXmlElement* origin = copy.FirstChildElement("origin");
          double xyz[3] = {0.0, 0.0, 0.0};
          if (origin && origin->Attribute("xyz")) {
            std::istringstream in(origin->Attribute("xyz"));
            in.imbue(std::locale::classic());
            in >> xyz[0] >> xyz[1] >> xyz[2];
          } else if (!origin) {
            copy.InsertEndChild(TiXmlElement("origin"));
            origin = copy.FirstChildElement("origin");
          }
          xyz[0] -= i * spacing;
          origin->SetAttribute("xyz", fixed_number(xyz[0]) + " " + fixed_number(xyz[1]) + " " + fixed_number(xyz[2]));
        }
      }
      out_robot.InsertEndChild(copy);
    }
    for (const TiXmlElement* e = loops->FirstChildElement("loop_joint"); e; e = e->NextSiblingElement("loop_joint")) {
      TiXmlElement copy(*e);
      if (const char* n = copy.Attribute("name")) copy.SetAttribute("name", prefix + n);
      prefix_child(&copy, "parent", "link", prefix, world);
      prefix_child(&copy, "child", "link", prefix, world);
      out_loops.InsertEndChild(copy);
    }
  }
  for (int i = 0; i + 1 < vehicles; ++i) {
    TiXmlElement hitch("loop_joint");
    hitch.SetAttribute("name", "hitch_" + std::to_string(i));
    hitch.SetAttribute("type", "spherical");
    TiXmlElement parent("parent"), child("child"), origin("origin"), child_origin("child_origin");
    parent.SetAttribute("link", "v" + std::to_string(i) + "_" + root_link);
    child.SetAttribute("link", "v" + std::to_string(i + 1) + "_" + root_link);
    origin.SetAttribute("xyz", fixed_number(-spacing / 2) + " 0 0");
    origin.SetAttribute("rpy", "0 0 0");
    child_origin.SetAttribute("xyz", fixed_number(spacing / 2) + " 0 0");
    child_origin.SetAttribute("rpy", "0 0 0");
    hitch.InsertEndChild(parent);
    hitch.InsertEndChild(child);
    hitch.InsertEndChild(origin);
    hitch.InsertEndChild(child_origin);
    out_loops.InsertEndChild(hitch);
  }
  out_urdf.InsertEndChild(out_robot);
  TiXmlDocument out_cuts;
  out_cuts.InsertEndChild(TiXmlDeclaration("1.0", "", ""));
  out_cuts.InsertEndChild(out_loops);
  TiXmlPrinter p1, p2;
  p1.SetIndent("  ");
  p2.SetIndent("  ");
  out_urdf.Accept(&p1);
  out_cuts.Accept(&p2);
  return {p1.Str(), p2.Str()};
}

}  // namespace jrgen::testing
