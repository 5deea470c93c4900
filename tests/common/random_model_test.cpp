// Tests of the random URDF generators (random_model.hpp).
#include "random_model.hpp"

#include <gtest/gtest.h>
#include <tinyxml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

// Folder of the read-only real-world URDFs; the build may define it.
#ifndef JRGEN_MODELS_EXTERNAL_DIR
#define JRGEN_MODELS_EXTERNAL_DIR ""
#endif

namespace {

using jrgen::testing::add_floating_base;
using jrgen::testing::chain_urdf;
using jrgen::testing::random_tree_urdf;
using jrgen::testing::RandomTreeOptions;

std::filesystem::path external_models_dir() {
  std::filesystem::path dir = JRGEN_MODELS_EXTERNAL_DIR;
  if (dir.empty())  // <project>/../shared/models-external (not from __FILE__, which ccache may make relative)
    dir = std::filesystem::path(JRGEN_SOURCE_DIR) / ".." / "shared" / "models-external";
  return dir;
}

struct ParsedJoint {
  std::string name, type, parent, child;
  std::vector<double> axis;  // empty when absent
};

// A URDF read with TinyXML: links (document order), joints, root, depths.
struct Parsed {
  std::string robot_name;
  std::vector<std::string> links;
  std::vector<ParsedJoint> joints;
  std::string root;
  std::map<std::string, int> depth;
};

std::vector<double> numbers(const char* text) {
  std::vector<double> v;
  if (!text) return v;
  std::istringstream is(text);
  is.imbue(std::locale::classic());
  double x;
  while (is >> x) v.push_back(x);
  return v;
}

// Parses and checks the tree structure; reports failures through gtest.
Parsed parse(const std::string& text) {
  Parsed p;
  TiXmlDocument doc;
  doc.Parse(text.c_str(), nullptr, TIXML_ENCODING_UTF8);
  EXPECT_FALSE(doc.Error()) << doc.ErrorDesc() << " at line " << doc.ErrorRow();
  const TiXmlElement* robot = doc.RootElement();
  if (!robot || robot->ValueStr() != "robot") {
    ADD_FAILURE() << "no <robot> root element";
    return p;
  }
  if (const char* n = robot->Attribute("name")) p.robot_name = n;
  std::set<std::string> names;
  for (const TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const char* n = e->Attribute("name");
    EXPECT_NE(n, nullptr);
    if (!n) continue;
    EXPECT_TRUE(names.insert(n).second) << "duplicate link " << n;
    p.links.emplace_back(n);
  }
  std::map<std::string, std::string> parent_of;
  for (const TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    ParsedJoint j;
    const TiXmlElement* pa = e->FirstChildElement("parent");
    const TiXmlElement* ch = e->FirstChildElement("child");
    EXPECT_TRUE(e->Attribute("name") && e->Attribute("type") && pa && ch && pa->Attribute("link") && ch->Attribute("link"));
    if (!(e->Attribute("name") && e->Attribute("type") && pa && ch && pa->Attribute("link") && ch->Attribute("link")))
      continue;
    j.name = e->Attribute("name");
    j.type = e->Attribute("type");
    j.parent = pa->Attribute("link");
    j.child = ch->Attribute("link");
    if (const TiXmlElement* a = e->FirstChildElement("axis")) j.axis = numbers(a->Attribute("xyz"));
    EXPECT_TRUE(names.count(j.parent)) << j.name << ": unknown parent " << j.parent;
    EXPECT_TRUE(names.count(j.child)) << j.name << ": unknown child " << j.child;
    EXPECT_TRUE(parent_of.emplace(j.child, j.parent).second) << j.child << " has two parents";
    p.joints.push_back(j);
  }
  int roots = 0;
  for (const auto& l : p.links)
    if (!parent_of.count(l)) {
      p.root = l;
      ++roots;
    }
  EXPECT_EQ(roots, 1);
  for (const auto& l : p.links) {  // depth by walking up; a cycle shows as a too long walk
    int d = 0;
    std::string at = l;
    while (parent_of.count(at) && d <= static_cast<int>(p.links.size())) {
      at = parent_of[at];
      ++d;
    }
    EXPECT_LE(d, static_cast<int>(p.links.size())) << "cycle through " << l;
    p.depth[l] = d;
  }
  return p;
}

// Every <inertial> has a positive mass and a positive definite inertia that
// satisfies the triangle inequality.
void expect_valid_inertias(const std::string& text) {
  TiXmlDocument doc;
  doc.Parse(text.c_str(), nullptr, TIXML_ENCODING_UTF8);
  ASSERT_FALSE(doc.Error());
  for (const TiXmlElement* e = doc.RootElement()->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const std::string name = e->Attribute("name");
    const TiXmlElement* in = e->FirstChildElement("inertial");
    if (name == "world") {
      EXPECT_EQ(in, nullptr);
      continue;
    }
    ASSERT_NE(in, nullptr) << name;
    double m = 0;
    ASSERT_EQ(in->FirstChildElement("mass")->QueryDoubleAttribute("value", &m), TIXML_SUCCESS);
    EXPECT_GT(m, 0.0) << name;
    const TiXmlElement* t = in->FirstChildElement("inertia");
    ASSERT_NE(t, nullptr);
    auto g = [&](const char* a) {
      double v = 0;
      EXPECT_EQ(t->QueryDoubleAttribute(a, &v), TIXML_SUCCESS) << name << " " << a;
      return v;
    };
    Eigen::Matrix3d I;
    I << g("ixx"), g("ixy"), g("ixz"), g("ixy"), g("iyy"), g("iyz"), g("ixz"), g("iyz"), g("izz");
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
    EXPECT_GT(ev[0], 0.0) << name;
    EXPECT_GT(ev[0] + ev[1], ev[2]) << name << ": triangle inequality";
  }
}

const std::set<std::string> kTreeTypes = {"revolute", "continuous", "prismatic", "ball", "planar", "fixed", "floating"};

void expect_valid_axes(const Parsed& p) {
  for (const auto& j : p.joints) {
    EXPECT_TRUE(kTreeTypes.count(j.type)) << j.type;
    if (j.type == "revolute" || j.type == "continuous" || j.type == "prismatic" || j.type == "planar") {
      ASSERT_EQ(j.axis.size(), 3u) << j.name;
      EXPECT_NEAR(std::hypot(j.axis[0], j.axis[1], j.axis[2]), 1.0, 1e-12) << j.name;
      if (j.type == "planar") {
        const int ones = std::count(j.axis.begin(), j.axis.end(), 1.0);
        const int zeros = std::count(j.axis.begin(), j.axis.end(), 0.0);
        EXPECT_TRUE(ones == 1 && zeros == 2) << j.name << ": planar normal must be a coordinate axis";
      }
    }
  }
}

TEST(RandomModel, SameSeedSameText) {
  RandomTreeOptions o;
  o.seed = 42;
  o.num_bodies = 25;
  o.mass_ratio = 100.0;
  EXPECT_EQ(random_tree_urdf(o), random_tree_urdf(o));
  o.floating_base = true;
  o.max_depth = 4;
  EXPECT_EQ(random_tree_urdf(o), random_tree_urdf(o));
  EXPECT_EQ(chain_urdf(12, 7), chain_urdf(12, 7));
}

TEST(RandomModel, DifferentSeedsDifferentText) {
  RandomTreeOptions a, b;
  a.seed = 1;
  b.seed = 2;
  EXPECT_NE(random_tree_urdf(a), random_tree_urdf(b));
  EXPECT_NE(chain_urdf(5, 1), chain_urdf(5, 2));
}

TEST(RandomModel, TreeBodyCountsAndNames) {
  for (int n : {1, 2, 7, 30, 150}) {
    for (bool floating : {false, true}) {
      RandomTreeOptions o;
      o.seed = 1000 + n;
      o.num_bodies = n;
      o.floating_base = floating;
      const Parsed p = parse(random_tree_urdf(o));
      EXPECT_EQ(p.robot_name, "random_" + std::to_string(o.seed) + "_" + std::to_string(n));
      EXPECT_EQ(p.links.size(), static_cast<size_t>(n + 1));
      EXPECT_EQ(p.joints.size(), static_cast<size_t>(n));
      EXPECT_EQ(p.root, "world");
      int floating_joints = 0, world_children = 0;
      for (const auto& j : p.joints) {
        floating_joints += j.type == "floating";
        world_children += j.parent == "world";
      }
      EXPECT_EQ(floating_joints, floating ? 1 : 0);
      if (floating) {
        EXPECT_EQ(p.joints.front().type, "floating");
        EXPECT_EQ(world_children, 1);
      }
    }
  }
}

TEST(RandomModel, ChainIsSerialRevolute) {
  for (int n : {1, 6, 40}) {
    const Parsed p = parse(chain_urdf(n, 3));
    EXPECT_EQ(p.robot_name, "chain_3_" + std::to_string(n));
    ASSERT_EQ(p.joints.size(), static_cast<size_t>(n));
    EXPECT_EQ(p.links.size(), static_cast<size_t>(n + 1));
    std::string parent = "world";
    for (const auto& j : p.joints) {
      EXPECT_EQ(j.type, "revolute");
      EXPECT_EQ(j.parent, parent);
      parent = j.child;
    }
    EXPECT_EQ(p.depth.at(parent), n);
  }
}

TEST(RandomModel, DepthBoundRespected) {
  for (int max_depth : {1, 2, 3, 5}) {
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      for (bool floating : {false, true}) {
        if (floating && max_depth == 1) continue;
        RandomTreeOptions o;
        o.seed = seed;
        o.num_bodies = 60;
        o.max_depth = max_depth;
        o.floating_base = floating;
        const Parsed p = parse(random_tree_urdf(o));
        int deepest = 0;
        for (const auto& [link, d] : p.depth) deepest = std::max(deepest, d);
        EXPECT_LE(deepest, max_depth) << "seed " << seed;
        // 60 bodies do not fit below the bound without reaching it.
        EXPECT_EQ(deepest, max_depth) << "seed " << seed;
      }
    }
  }
  // Unbounded: deep trees do occur.
  RandomTreeOptions o;
  o.num_bodies = 200;
  const Parsed p = parse(random_tree_urdf(o));
  int deepest = 0;
  for (const auto& [link, d] : p.depth) deepest = std::max(deepest, d);
  EXPECT_GT(deepest, 3);
}

// A scene of mechanisms: every group of B consecutive bodies is one
// mechanism hanging from the world, within the depth bound, and the scene's
// shape statistics do not depend on its size (the same groups, drawn the
// same way, come first in a larger scene).
TEST(RandomModel, SceneOfMechanisms) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    RandomTreeOptions o;
    o.seed = seed;
    o.num_bodies = 50;
    o.max_depth = 3;
    o.mechanism_bodies = 7;
    const Parsed p = parse(random_tree_urdf(o));
    std::map<std::string, std::string> parent_of;
    for (const auto& j : p.joints) parent_of[j.child] = j.parent;
    int on_world = 0;
    for (int i = 1; i <= o.num_bodies; ++i) {
      const std::string body = "body_" + std::to_string(i);
      const int first = 1 + (i - 1) / 7 * 7;
      std::string top = body;  // the body of this mechanism that hangs from the world
      while (parent_of.at(top) != "world") top = parent_of.at(top);
      EXPECT_EQ(top, "body_" + std::to_string(first)) << "seed " << seed << ", " << body;
      EXPECT_LE(p.depth.at(body), 3) << "seed " << seed << ", " << body;
      on_world += parent_of.at(body) == "world";
    }
    EXPECT_EQ(on_world, 8) << "seed " << seed;  // ceil(50 / 7) mechanisms
  }
  // The mechanisms of a small scene are drawn exactly as the first ones of a
  // larger scene with the same seed.
  RandomTreeOptions small, large;
  small.num_bodies = 40;
  large.num_bodies = 400;
  small.max_depth = large.max_depth = 8;
  small.mechanism_bodies = large.mechanism_bodies = 20;
  const std::string a = random_tree_urdf(small), b = random_tree_urdf(large);
  const std::string::size_type joint_41 = b.find("<joint name=\"joint_41\"");
  ASSERT_NE(joint_41, std::string::npos);
  const std::string::size_type a_start = a.find("  <joint"), b_start = b.find("  <joint");
  const std::string::size_type b_end = b.rfind('\n', joint_41) + 1;  // the start of joint_41's line
  EXPECT_EQ(a.substr(a_start, a.find("</robot>") - a_start), b.substr(b_start, b_end - b_start));
}

TEST(RandomModel, WellFormedTypesAxesInertias) {
  std::map<std::string, int> seen;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    RandomTreeOptions o;
    o.seed = seed;
    o.num_bodies = 40;
    o.floating_base = seed % 2 == 0;
    o.mass_ratio = 1000.0;
    o.damping = seed % 3 != 0;
    const std::string text = random_tree_urdf(o);
    const Parsed p = parse(text);
    expect_valid_axes(p);
    expect_valid_inertias(text);
    for (const auto& j : p.joints) ++seen[j.type];
    EXPECT_EQ(text.find("<dynamics") != std::string::npos, o.damping);
  }
  for (const auto& t : kTreeTypes) EXPECT_GT(seen[t], 0) << t << " never drawn";
  const std::string chain = chain_urdf(30, 9);
  expect_valid_axes(parse(chain));
  expect_valid_inertias(chain);
}

TEST(RandomModel, JointTypeWeightsAreHonoured) {
  RandomTreeOptions o;
  o.num_bodies = 100;
  o.p_revolute = 0;
  o.p_continuous = 0;
  o.p_prismatic = 1;
  o.p_ball = 0;
  o.p_planar = 0;
  o.p_fixed = 0;
  for (const auto& j : parse(random_tree_urdf(o)).joints) EXPECT_EQ(j.type, "prismatic");
}

TEST(RandomModel, MassesWithinRatio) {
  RandomTreeOptions o;
  o.num_bodies = 200;
  o.mass_ratio = 50.0;
  TiXmlDocument doc;
  doc.Parse(random_tree_urdf(o).c_str(), nullptr, TIXML_ENCODING_UTF8);
  ASSERT_FALSE(doc.Error());
  double lo = 1e300, hi = 0;
  for (const TiXmlElement* e = doc.RootElement()->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const TiXmlElement* in = e->FirstChildElement("inertial");
    if (!in) continue;
    double m = 0;
    in->FirstChildElement("mass")->QueryDoubleAttribute("value", &m);
    lo = std::min(lo, m);
    hi = std::max(hi, m);
  }
  EXPECT_GE(lo, 1.0);
  EXPECT_LE(hi, 50.0);
  EXPECT_GT(hi / lo, 10.0);  // spread over the range
}

TEST(RandomModel, BadOptionsThrow) {
  RandomTreeOptions o;
  o.num_bodies = 0;
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  o.num_bodies = 3;
  o.floating_base = true;
  o.max_depth = 1;
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  o = RandomTreeOptions{};
  o.mass_ratio = 0.5;
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  o = RandomTreeOptions{};
  o.p_revolute = o.p_continuous = o.p_prismatic = o.p_ball = o.p_planar = o.p_fixed = 0;
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  EXPECT_THROW(chain_urdf(0, 1), std::invalid_argument);
  o = RandomTreeOptions{};
  o.mechanism_bodies = -1;
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  o.mechanism_bodies = 5;
  o.floating_base = true;
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  o.floating_base = false;
  o.max_depth = 1;  // a mechanism's second body would have nowhere to attach
  EXPECT_THROW(random_tree_urdf(o), std::invalid_argument);
  o.mechanism_bodies = 1;  // one body per mechanism: all on the world
  const Parsed p = parse(random_tree_urdf(o));
  for (const auto& j : p.joints) EXPECT_EQ(j.parent, "world") << j.name;
}

// add_floating_base: jr_world becomes the root, with one floating joint to the
// old root; everything else is kept.
void expect_floating_base_added(const std::string& before_text, const std::string& label) {
  SCOPED_TRACE(label);
  const Parsed before = parse(before_text);
  const std::string after_text = add_floating_base(before_text);
  const Parsed after = parse(after_text);
  EXPECT_EQ(after.robot_name, before.robot_name);
  EXPECT_EQ(after.root, "jr_world");
  ASSERT_EQ(after.links.size(), before.links.size() + 1);
  ASSERT_EQ(after.joints.size(), before.joints.size() + 1);
  EXPECT_EQ(after.links.front(), "jr_world");
  const ParsedJoint& j = after.joints.front();
  EXPECT_EQ(j.name, "jr_floating_base");
  EXPECT_EQ(j.type, "floating");
  EXPECT_EQ(j.parent, "jr_world");
  EXPECT_EQ(j.child, before.root);
  EXPECT_TRUE(std::equal(before.links.begin(), before.links.end(), after.links.begin() + 1));
  for (size_t i = 0; i < before.joints.size(); ++i) {
    EXPECT_EQ(after.joints[i + 1].name, before.joints[i].name);
    EXPECT_EQ(after.joints[i + 1].child, before.joints[i].child);
  }
  for (const auto& [link, d] : before.depth) EXPECT_EQ(after.depth.at(link), d + 1) << link;
  // Adding it twice is an error.
  EXPECT_THROW(add_floating_base(after_text), std::invalid_argument);
}

TEST(AddFloatingBase, ExternalModels) {
  const std::filesystem::path dir = external_models_dir();
  ASSERT_TRUE(std::filesystem::is_directory(dir)) << "no " << dir << " (the external robots the suite reads)";
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".urdf") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_FALSE(files.empty());
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    ASSERT_TRUE(in) << f;
    std::stringstream ss;
    ss << in.rdbuf();
    expect_floating_base_added(ss.str(), f.filename().string());
  }
}

TEST(AddFloatingBase, GeneratedModels) {
  RandomTreeOptions o;
  o.num_bodies = 15;
  expect_floating_base_added(random_tree_urdf(o), "random tree");
  expect_floating_base_added(chain_urdf(4, 2), "chain");
}

TEST(AddFloatingBase, RejectsBadInput) {
  EXPECT_THROW(add_floating_base("<robot name=\"x\"><link name=\"a\"/>"), std::invalid_argument);
  EXPECT_THROW(add_floating_base("<notrobot/>"), std::invalid_argument);
  // Two roots.
  EXPECT_THROW(add_floating_base("<robot name=\"x\"><link name=\"a\"/><link name=\"b\"/></robot>"),
               std::invalid_argument);
}

}  // namespace
