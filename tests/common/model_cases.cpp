#include "common/model_cases.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <tinyxml.h>

#include "common/random_cuts.hpp"
#include "common/random_model.hpp"
#include "urdf/urdf_reader.hpp"

#ifndef JRGEN_SOURCE_DIR
#error "JRGEN_SOURCE_DIR must be defined"
#endif

namespace fs = std::filesystem;

namespace jrgen::testing {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

namespace {
// The model's text without the force elements of docs/interface.md 2b (<spring>,
// <joint_spring>, <joint_force>): the independent reference dynamics
// (tests/reference/) knows none, so the cases that compare against it see the
// mechanism alone.  The force elements have their own tests (forces_test,
// published_test on the published models with springs and motors).
std::string without_force_elements(const std::string& urdf) {
  if (urdf.find("<spring") == std::string::npos && urdf.find("<joint_spring") == std::string::npos &&
      urdf.find("<joint_force") == std::string::npos)
    return urdf;
  TiXmlDocument doc;
  doc.Parse(urdf.c_str());
  if (doc.Error()) throw std::runtime_error(std::string("without_force_elements: ") + doc.ErrorDesc());
  TiXmlElement* robot = doc.RootElement();
  for (const char* tag : {"spring", "joint_spring", "joint_force"})
    while (TiXmlElement* e = robot->FirstChildElement(tag)) robot->RemoveChild(e);
  TiXmlPrinter printer;
  doc.Accept(&printer);
  return printer.CStr();
}

std::vector<fs::path> sorted_urdfs(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".urdf") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}
}  // namespace

std::vector<ModelCase> project_tree_models() {
  std::vector<ModelCase> out;
  for (const fs::path& p : sorted_urdfs(fs::path(JRGEN_SOURCE_DIR) / "models")) {
    std::string text = without_force_elements(read_text(p.string()));
    if (text.find("<loop_joint") != std::string::npos) continue;
    out.push_back({p.stem().string(), std::move(text)});
  }
  return out;
}

std::string give_massless_links_inertia(const std::string& urdf) {
  TiXmlDocument doc;
  doc.Parse(urdf.c_str());
  if (doc.Error()) throw std::runtime_error(std::string("give_massless_links_inertia: ") + doc.ErrorDesc());
  TiXmlElement* robot = doc.RootElement();
  for (TiXmlElement* link = robot->FirstChildElement("link"); link; link = link->NextSiblingElement("link")) {
    if (TiXmlElement* old = link->FirstChildElement("inertial")) {
      const TiXmlElement* m = old->FirstChildElement("mass");
      double value = 0.0;
      if (m && m->QueryDoubleAttribute("value", &value) == TIXML_SUCCESS && value > 0.0) continue;
      link->RemoveChild(old);
    }
    TiXmlElement inertial("inertial");
    TiXmlElement mass("mass");
    mass.SetAttribute("value", "0.01");
    TiXmlElement inertia("inertia");
    for (const char* a : {"ixx", "iyy", "izz"}) inertia.SetAttribute(a, "1e-6");
    for (const char* a : {"ixy", "ixz", "iyz"}) inertia.SetAttribute(a, "0");
    inertial.InsertEndChild(mass);
    inertial.InsertEndChild(inertia);
    link->InsertEndChild(inertial);
  }
  TiXmlPrinter printer;
  doc.Accept(&printer);
  return printer.CStr();
}

// The URDF without its joints' <mimic> elements.  Since docs/interface.md section
// 2b a <mimic> is a constraint row, which would make closed-loop models of
// baxter, panda, pr2, romeo and talos; the external cases test the tree
// dynamics (against the reference and the peers, which treat mimic joints as
// free), so they drop them.  Mimic rows are tested in tests/generated/forces_test.cpp.
std::string without_mimic(const std::string& urdf) {
  TiXmlDocument doc;
  doc.Parse(urdf.c_str());
  TiXmlElement* robot = doc.RootElement();
  for (TiXmlElement* j = robot->FirstChildElement("joint"); j != nullptr; j = j->NextSiblingElement("joint"))
    while (TiXmlElement* m = j->FirstChildElement("mimic")) j->RemoveChild(m);
  TiXmlPrinter printer;
  doc.Accept(&printer);
  return printer.CStr();
}

std::vector<ModelCase> external_models() {
  std::vector<ModelCase> out;
  for (const fs::path& p : sorted_urdfs(fs::path(JRGEN_SOURCE_DIR) / ".." / "shared" / "models-external")) {
    std::string text = add_floating_base(read_text(p.string()));
    if (text.find("<mimic") != std::string::npos) text = without_mimic(text);
    std::string name = "ext_" + p.stem().string();
    // romeo moves links without any <inertial> (its hands), so its mass matrix
    // is singular as written: jrgen rejects it (tests/generator/cli_test).
    // Its dynamics are tested on a copy whose massless links get 10 g.
    if (p.stem() == "romeo") {
      text = give_massless_links_inertia(text);
      name += "_patched";
    }
    out.push_back({name, std::move(text)});
  }
  return out;
}

std::vector<ModelCase> fixed_base_robots() {
  const fs::path p = fs::path(JRGEN_SOURCE_DIR) / ".." / "shared" / "models-external" / "icub.urdf";
  return {{"fixed_icub", without_mimic(read_text(p.string()))}};
}

std::vector<ModelCase> extreme_in_time() {
  std::vector<ModelCase> out;
  for (const fs::path& p : sorted_urdfs(fs::path(JRGEN_SOURCE_DIR) / "tests" / "simulate" / "extreme")) {
    std::string text = read_text(p.string());
    const bool loops = text.find("<loop_joint") != std::string::npos;
    out.push_back({(loops ? "loops_xt_" : "xt_") + p.stem().string(), std::move(text)});
  }
  return out;
}

std::vector<ModelCase> random_trees() {
  std::vector<ModelCase> out;
  const int sizes[] = {1, 2, 3, 5, 8, 13, 30, 60, 120, 250, 500};
  std::uint64_t seed = 1;
  for (int n : sizes) {
    RandomTreeOptions o;
    o.seed = seed++;
    o.num_bodies = n;
    o.floating_base = n % 2 == 0;
    out.push_back({"random_" + std::to_string(n) + "_seed" + std::to_string(o.seed), random_tree_urdf(o)});
  }
  // A 200-joint chain: M is dense, and the unrolled factorization would be too
  // large, so the generator emits the table-driven Steps 1, 2 and 4.
  out.push_back({"chain_200", chain_urdf(200, 3)});
  // Bounded depth (a scene of many small mechanisms).
  for (int n : {40, 200}) {
    RandomTreeOptions o;
    o.seed = seed++;
    o.num_bodies = n;
    o.max_depth = 4;
    out.push_back({"random_depth4_" + std::to_string(n), random_tree_urdf(o)});
  }
  // Stiff trees: body masses spread log-uniformly over 4 and 8 decades on a
  // floating base (tests/generated/extreme_test.cpp, docs/extreme.md).
  for (const auto& [label, ratio] : {std::pair{"1e4", 1e4}, std::pair{"1e8", 1e8}}) {
    RandomTreeOptions o;
    o.seed = seed++;
    o.num_bodies = 40;
    o.floating_base = true;
    o.mass_ratio = ratio;
    out.push_back({std::string("stiff_mass_") + label, random_tree_urdf(o)});
  }
  return out;
}

std::vector<ModelCase> loop_models() {
  std::vector<ModelCase> out;
  const fs::path models = fs::path(JRGEN_SOURCE_DIR) / "models";
  for (const fs::path& p : sorted_urdfs(models)) {
    std::string text = without_force_elements(read_text(p.string()));
    fs::path cuts = p;
    cuts.replace_extension(".cuts.xml");
    const bool has_file = fs::exists(cuts);
    if (!has_file && text.find("<loop_joint") == std::string::npos) continue;
    out.push_back({"loops_" + p.stem().string(), std::move(text), has_file ? read_text(cuts.string()) : ""});
  }
  // The four-bar without <dynamics damping>: a conservative closed loop, for
  // the energy test (tests/generated/energy_test.cpp).
  {
    TiXmlDocument doc;
    const std::string text = read_text((models / "fourbar.urdf").string());
    doc.Parse(text.c_str());
    if (doc.Error()) throw std::runtime_error(std::string("fourbar.urdf: ") + doc.ErrorDesc());
    for (TiXmlElement* joint = doc.RootElement()->FirstChildElement("joint"); joint;
         joint = joint->NextSiblingElement("joint"))
      while (TiXmlElement* dynamics = joint->FirstChildElement("dynamics")) joint->RemoveChild(dynamics);
    TiXmlPrinter printer;
    doc.Accept(&printer);
    out.push_back({"loops_fourbar_conservative", printer.CStr(), ""});
  }
  // A parallelogram four-bar (issue 19, items 4 and 6): ground pivots
  // A = (0,0,0), D = (1,0,0), crank AB, coupler BC and rocker CD all 1 m
  // (uniform 1 kg rods), drawn at q = 0 as a square (B = (0,1,0),
  // C = (1,1,0)); closed at D by a 3-D revolute cut, reduced to 2 rows.  At
  // q = (pi/2, -pi/2, pi/2) it is assembled with all bars on the x axis: the
  // change point between the parallelogram and the anti-parallelogram
  // branches, where Phiq loses rank (singular values 1.41 and 0).
  {
    auto rod = [](const char* name, const char* com, double ixx, double iyy) {
      return fmt::format(
          "  <link name=\"{}\"><inertial><origin xyz=\"{}\" rpy=\"0 0 0\"/><mass value=\"1\"/>"
          "<inertia ixx=\"{}\" ixy=\"0\" ixz=\"0\" iyy=\"{}\" iyz=\"0\" izz=\"{}\"/></inertial></link>\n",
          name, com, ixx, iyy, 1.0 / 12.0);
    };
    auto joint = [](const char* name, const char* parent, const char* child, const char* xyz) {
      return fmt::format(
          "  <joint name=\"{}\" type=\"revolute\"><parent link=\"{}\"/><child link=\"{}\"/>"
          "<origin xyz=\"{}\" rpy=\"0 0 0\"/><axis xyz=\"0 0 1\"/>"
          "<limit lower=\"-1000\" upper=\"1000\" effort=\"100\" velocity=\"50\"/></joint>\n",
          name, parent, child, xyz);
    };
    std::string urdf = "<?xml version=\"1.0\"?>\n<robot name=\"parallelogram\">\n  <link name=\"world\"/>\n";
    urdf += joint("joint_A", "world", "crank", "0 0 0") + rod("crank", "0 0.5 0", 1.0 / 12.0, 1e-3) +
            joint("joint_B", "crank", "coupler", "0 1 0") + rod("coupler", "0.5 0 0", 1e-3, 1.0 / 12.0) +
            joint("joint_C", "coupler", "rocker", "1 0 0") + rod("rocker", "0 -0.5 0", 1.0 / 12.0, 1e-3);
    urdf +=
        "  <loop_joint name=\"joint_D\" type=\"revolute\"><parent link=\"rocker\"/><child link=\"world\"/>"
        "<origin xyz=\"0 -1 0\" rpy=\"0 0 0\"/><child_origin xyz=\"1 0 0\" rpy=\"0 0 0\"/>"
        "<axis xyz=\"0 0 1\"/></loop_joint>\n</robot>\n";
    out.push_back({"loops_parallelogram", urdf, ""});
  }
  // The four-bar with joint and loop-joint names of 300 characters (issue
  // 19, item 2): the generated code must still compile with -Wall -Wextra
  // -Werror (no -Wformat-truncation in its error messages).
  {
    std::string text = read_text((models / "fourbar.urdf").string());
    for (const char* name : {"joint_A", "joint_B", "joint_C", "joint_D"}) {
      const std::string quoted = std::string("\"") + name + "\"";
      const std::string longer = std::string("\"") + name + std::string(293, 'x') + "\"";
      for (std::size_t at = text.find(quoted); at != std::string::npos; at = text.find(quoted, at + longer.size()))
        text.replace(at, quoted.size(), longer);
    }
    out.push_back({"loops_long_names", text, ""});
  }
  // The four-bar with adversarial names (docs/interface.md section 1: generated
  // code compiles with -Wall -Wextra -Werror whatever the names): a 300
  // character joint name, quotes and backslashes, printf directives, comment
  // delimiters, trigraphs (-Wtrigraphs), a line break, a tab, markup and
  // non-ASCII text.
  {
    std::string text = read_text((models / "fourbar.urdf").string());
    const std::pair<std::string, std::string> renames[] = {
        {"\"joint_A\"", "\"" + std::string(300, 'A') + "\""},
        {"\"joint_B\"", "\"q&quot;uote\\back\\\\slash\\\""},
        {"\"joint_C\"", "\"%s%n%99999d */ /* ?\?/ line&#10;break\""},
        {"\"joint_D\"", "\"cut &quot;D&quot; \\ ?\?= \u00e9\u4e2d ?\?\?\""},
        {"\"crank\"", "\"&lt;crank&gt; \u00fc\""},
        {"\"coupler\"", "\"coupler&#9;tab\""},
        {"\"fourbar\"", "\"four&quot;bar\\ */\""}};
    for (const auto& [from, to] : renames) {
      if (text.find(from) == std::string::npos) throw std::runtime_error("fourbar.urdf: no " + from);
      for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
        text.replace(at, from.size(), to);
    }
    out.push_back({"loops_weird_names", text, ""});
  }
  // The HMMWV without its left rear toe link: 15 constraint rows, all
  // reaching the chassis, so the dense Steps 3.3-3.4 run the square layout
  // with m odd (its padding row; jrgen/constraint_solve.hpp).
  {
    TiXmlDocument doc;
    const std::string text = read_text((models / "hmmwv14.cuts.xml").string());
    doc.Parse(text.c_str());
    if (doc.Error()) throw std::runtime_error(std::string("hmmwv14.cuts.xml: ") + doc.ErrorDesc());
    TiXmlElement* root = doc.RootElement();
    TiXmlElement* cut = root->FirstChildElement("loop_joint");
    while (cut && std::string(cut->Attribute("name") ? cut->Attribute("name") : "") != "lr_toe_link")
      cut = cut->NextSiblingElement("loop_joint");
    if (!cut) throw std::runtime_error("hmmwv14.cuts.xml: no loop joint 'lr_toe_link'");
    root->RemoveChild(cut);
    TiXmlPrinter printer;
    doc.Accept(&printer);
    out.push_back({"loops_hmmwv14_m15", read_text((models / "hmmwv14.urdf").string()), printer.CStr()});
  }
  // Random trees with random cuts; seeds 1..7 start the type cycle at every
  // cut type, so each type appears first somewhere.
  const int sizes[] = {4, 6, 9, 12, 20, 35, 60};
  for (std::uint64_t seed = 1; seed <= 7; ++seed) {
    RandomTreeOptions o;
    o.seed = 100 + seed;
    o.num_bodies = sizes[seed - 1];
    o.floating_base = seed % 3 == 0;
    const std::string urdf = random_tree_urdf(o);
    RandomCutOptions co;
    co.seed = seed;
    co.num_cuts = 1 + static_cast<int>(seed % 3);
    out.push_back({"loops_random_" + std::to_string(o.num_bodies) + "_seed" + std::to_string(seed), urdf,
                   random_cuts_xml(urdf, co)});
  }
  // A stiff closed loop: masses over 6 decades, two random cuts.
  {
    RandomTreeOptions o;
    o.seed = 400;
    o.num_bodies = 20;
    o.mass_ratio = 1e6;
    const std::string urdf = random_tree_urdf(o);
    RandomCutOptions co;
    co.seed = 3;
    co.num_cuts = 2;
    out.push_back({"loops_stiff_mass_1e6", urdf, random_cuts_xml(urdf, co)});
  }
  // Vehicle trains (random_model.hpp, vehicle_train): 2 and 3 HMMWVs hitched
  // by spherical cut joints; T^T T is block tridiagonal.
  for (int k : {2, 3}) {
    const ModelWithCuts train = vehicle_train(k, read_text((models / "hmmwv14.urdf").string()),
                                              read_text((models / "hmmwv14.cuts.xml").string()));
    out.push_back({"loops_train_" + std::to_string(k), train.urdf, train.cuts});
  }
  return out;
}

std::vector<ModelCase> all_models() {
  std::vector<ModelCase> out = all_tree_models();
  std::vector<ModelCase> more = loop_models();
  out.insert(out.end(), more.begin(), more.end());
  return out;
}

namespace {

// A rope of n revolute joints hanging straight down (links of 1 mm, axes
// alternating y and x) whose tip is tied to the base by a spherical cut
// joint: assembled at q = 0, where the vertical row is redundant (the rope
// is stretched) and dropped, the two horizontal rows kept.
ModelCase hanging_rope_loop(int n) {
  std::string urdf = "<robot name=\"rope_" + std::to_string(n) + "\">\n<link name=\"l0\"/>\n";
  for (int i = 1; i <= n; ++i) {
    urdf += fmt::format(
        "<link name=\"l{0}\"><inertial><origin xyz=\"0 0 -0.0005\"/><mass value=\"0.01\"/>"
        "<inertia ixx=\"1e-6\" iyy=\"1e-6\" izz=\"1e-7\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
        "<joint name=\"j{0}\" type=\"continuous\"><parent link=\"l{1}\"/><child link=\"l{0}\"/>"
        "<origin xyz=\"0 0 -0.001\"/><axis xyz=\"{2}\"/></joint>\n",
        i, i - 1, i % 2 ? "0 1 0" : "1 0 0");
  }
  urdf += "</robot>\n";
  const std::string cuts = fmt::format(
      "<loop_joints>\n  <loop_joint name=\"tip_to_base\" type=\"spherical\">\n"
      "    <parent link=\"l{}\"/>\n    <child link=\"l0\"/>\n    <origin xyz=\"0 0 0\"/>\n"
      "    <child_origin xyz=\"0 0 {}\"/>\n  </loop_joint>\n</loop_joints>\n",
      n, -0.001 * n);
  return {"loops_rope_" + std::to_string(n), urdf, cuts};
}

}  // namespace

namespace {

// A 300-joint chain with a gimbal after joint 150: joints gimbal_a (z),
// gimbal_b (x) and gimbal_c (z) at one point, the two links between them of
// 1e-6 kg and 1e-12 kg m^2.  At gimbal_b = 0 the axes of gimbal_a and
// gimbal_c coincide with almost nothing inertial between them: M is singular
// to working precision there (as fixed-base icub's neck at its zero state),
// on a long chain (tests/generated/runtime_digits_test.cpp).
ModelCase gimbal_chain(int n) {
  std::string urdf = chain_urdf(n, 2029);
  const std::string half = std::to_string(n / 2), next = std::to_string(n / 2 + 1);
  const std::string from = "<parent link=\"link_" + half + "\"/>\n    <child link=\"link_" + next + "\"/>";
  const std::size_t at = urdf.find(from);
  if (at == std::string::npos) throw std::runtime_error("gimbal_chain: no joint_" + next);
  urdf.replace(at, from.size(), "<parent link=\"gimbal_3\"/>\n    <child link=\"link_" + next + "\"/>");
  std::string gimbal;
  const char* axes[] = {"0 0 1", "1 0 0", "0 0 1"};
  for (int k = 0; k < 3; ++k) {
    const std::string parent = k == 0 ? "link_" + half : "gimbal_" + std::to_string(k);
    gimbal += fmt::format(
        "  <joint name=\"gimbal_{}\" type=\"revolute\">\n    <parent link=\"{}\"/>\n    <child link=\"gimbal_{}\"/>\n"
        "    <origin xyz=\"{}\"/>\n    <axis xyz=\"{}\"/>\n"
        "    <limit lower=\"-3.14159\" upper=\"3.14159\" effort=\"100\" velocity=\"10\"/>\n  </joint>\n"
        "  <link name=\"gimbal_{}\">\n    <inertial>\n      <mass value=\"1e-6\"/>\n"
        "      <inertia ixx=\"1e-12\" ixy=\"0\" ixz=\"0\" iyy=\"1e-12\" iyz=\"0\" izz=\"1e-12\"/>\n"
        "    </inertial>\n  </link>\n",
        static_cast<char>('a' + k), parent, k + 1, k == 0 ? "0.1 0 0" : "0 0 0", axes[k], k + 1);
  }
  urdf.insert(urdf.rfind("</robot>"), gimbal);
  return {"chain_gimbal_" + std::to_string(n), urdf};
}

// The gimbal chain of n joints with its tip tied to a point of the world by a
// distance cut (one row): closed loops whose M goes singular with gimbal_b =
// 0 (the runtime's articulated route for loops, tests/generated/runtime_digits_test.cpp).
ModelCase gimbal_chain_loop(int n) {
  ModelCase c = gimbal_chain(n);
  c.name = "loops_gimbal_chain_" + std::to_string(n);
  c.cuts = fmt::format(
      "<loop_joints>\n  <loop_joint name=\"tip_tether\" type=\"distance\">\n"
      "    <parent link=\"link_{}\"/>\n    <child link=\"world\"/>\n    <origin xyz=\"0 0 0\"/>\n"
      "    <child_origin xyz=\"0.3 0.2 0.1\"/>\n  </loop_joint>\n</loop_joints>\n",
      n);
  return c;
}

}  // namespace

std::vector<ModelCase> long_chains() {
  return {{"chain_1000", chain_urdf(1000, 2026)}, {"chain_10000", chain_urdf(10000, 2026)}, hanging_rope_loop(300),
          gimbal_chain(300), gimbal_chain_loop(40)};
}

namespace {

// Each list of the cases, built once per process, on first use.
template <std::vector<ModelCase> (*Make)()>
const std::vector<ModelCase>& built_once() {
  static const std::vector<ModelCase> cases = Make();
  return cases;
}

}  // namespace

// The lists in the order of all_models() and then long_chains(), each built
// only when the lists before it do not hold the name.  ctest runs every test
// in a process of its own, which asks for one case: building every list (the
// 10 000-joint chain's URDF above all) cost each of the suite's ~2000 test
// processes about 0.2 s of CPU (docs/testing.md, "CI time").
const ModelCase& find_model_case(const std::string& name) {
  for (auto* list : {&built_once<project_tree_models>, &built_once<external_models>, &built_once<random_trees>,
                     &built_once<loop_models>, &built_once<long_chains>,
                     &built_once<fixed_base_robots>, &built_once<extreme_in_time>})
    for (const ModelCase& c : list())
      if (c.name == name) return c;
  throw std::runtime_error("no model case " + name);
}

ir::Robot read_model_case(const ModelCase& c) {
  ir::Robot robot = urdf::read_robot_string(c.urdf, c.name + ".urdf");
  if (!c.cuts.empty()) urdf::read_cuts_string(c.cuts, c.name + ".cuts.xml", robot);
  return robot;
}

std::vector<ModelCase> all_tree_models() {
  std::vector<ModelCase> out = project_tree_models();
  for (auto* f : {&external_models, &random_trees}) {
    std::vector<ModelCase> more = f();
    out.insert(out.end(), more.begin(), more.end());
  }
  return out;
}

}  // namespace jrgen::testing
