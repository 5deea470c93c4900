// --graph and --sparsity (emit/graph.cpp; docs/interface.md section 1, issue 22):
// the DOT text names every body with its Lemma 2 number, every tree joint
// with its type and every cut (dashed); the sparsity picture counts the
// entries Lemma 2 and Lemma 3 predict, recounted here from the definitions;
// the command line writes them with the solver or, on a bad name or a
// missing Graphviz, nothing at all.
#include "emit/graph.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "cli/run_jrgen.hpp"
#include "common/model_cases.hpp"
#include "ir/error.hpp"
#include "topology/topology.hpp"

namespace {

using jrgen::testing::ModelCase;
namespace cli = jrgen::cli_testing;

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

const ModelCase& find_case(const std::string& name) {
  static const std::vector<ModelCase> all = [] {
    std::vector<ModelCase> out = jrgen::testing::loop_models();
    for (const ModelCase& c : jrgen::testing::project_tree_models()) out.push_back(c);
    return out;
  }();
  for (const ModelCase& c : all)
    if (c.name == name) return c;
  throw std::runtime_error("no model case " + name);
}

TEST(TopologyDot, EveryBodyJointAndCutOnceWithItsLemma2Number) {
  const jrgen::ir::Robot robot = jrgen::testing::read_model_case(find_case("loops_hmmwv14"));
  const jrgen::topology::Tree tree = jrgen::topology::build_tree(robot);
  const std::string dot = jrgen::emit::topology_dot(robot, tree);
  ASSERT_FALSE(tree.cuts.empty());
  for (std::size_t i = 0; i < tree.bodies.size(); ++i) {
    const auto& b = tree.bodies[i];
    EXPECT_EQ(count(dot, "label=\"#" + std::to_string(i) + " " + robot.links[b.links[0]].name), 1U) << i;
    const std::string parent = b.parent_lem < 0 ? "base" : "b" + std::to_string(b.parent_lem);
    EXPECT_EQ(count(dot, parent + " -> b" + std::to_string(i) + " [label=\"" + b.joint_name + "\\n" +
                             jrgen::ir::joint_type_name(b.type) + "\"]"),
              1U)
        << b.joint_name;
  }
  for (const auto& c : tree.cuts) EXPECT_EQ(count(dot, "label=\"cut " + c.name + "\\n"), 1U) << c.name;
  EXPECT_EQ(count(dot, "style=dashed"), tree.cuts.size());
  EXPECT_EQ(count(dot, " -> "), tree.bodies.size() + tree.cuts.size());
}

TEST(TopologyDot, NamesAreEscaped) {
  jrgen::ir::Robot robot = jrgen::testing::read_model_case(find_case("loops_hmmwv14"));
  robot.links[0].name = "a\"b\\c";
  const jrgen::topology::Tree tree = jrgen::topology::build_tree(robot);
  const std::string dot = jrgen::emit::topology_dot(robot, tree);
  EXPECT_NE(dot.find("a\\\"b\\\\c"), std::string::npos);
}

// The pictures' entry counts against the definitions: L has, per dof, itself
// and its ancestors (depth + 1: no fill-in, Lemma 2); T has, per kept row of
// cut c, the dofs of Lemma 3; T^T T is dense within coupled cuts.
TEST(SparsitySvg, EntriesAreThoseOfLemmas2And3) {
  for (const std::string name : {"loops_hmmwv14", "loops_stewart", "arm7"}) {
    SCOPED_TRACE(name);
    const jrgen::ir::Robot robot = jrgen::testing::read_model_case(find_case(name));
    const jrgen::topology::Tree tree = jrgen::topology::build_tree(robot);
    const std::string svg = jrgen::emit::sparsity_svg(robot, tree);
    long long L = 0, T = 0, nc = 0;
    for (const int d : tree.dof_depth) L += d + 1;
    for (const auto& c : tree.cuts) {
      T += static_cast<long long>(c.kept_rows.size() * c.dofs.size());
      nc += static_cast<long long>(c.kept_rows.size());
    }
    EXPECT_NE(svg.find("L (" + std::to_string(L) + " entries"), std::string::npos);
    if (nc > 0) EXPECT_NE(svg.find("L^-1 Phiq^T (" + std::to_string(T) + ":"), std::string::npos);
    // One square per entry, plus the background and one frame per panel.
    const long long squares = static_cast<long long>(count(svg, "<rect ")) - 1 - (nc > 0 ? 3 : 1);
    EXPECT_GE(squares, L + T);
    EXPECT_LE(squares, L + T + nc * nc);
    EXPECT_EQ(svg.rfind("</svg>\n"), svg.size() - 7);
  }
}

TEST(RenderSvg, MissingGraphvizIsOneErrorNamingTheFix) {
  const char* saved = std::getenv("PATH");
  const std::string path = saved ? saved : "";
  ::setenv("PATH", "/nonexistent", 1);
  try {
    jrgen::emit::render_svg("digraph g { a -> b; }", "pic.svg");
    ADD_FAILURE() << "render_svg must fail without dot";
  } catch (const jrgen::Error& e) {
    EXPECT_NE(std::string(e.what()).find("apt-get install graphviz"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--graph pic.dot"), std::string::npos) << e.what();
  }
  ::setenv("PATH", path.c_str(), 1);
}

TEST(GraphCli, WritesDotAndSvgBesideTheSolver) {
  cli::ScratchDir dir("jrgen_graph");
  const auto r = cli::run_jrgen({(cli::kModelsDir / "hmmwv14.urdf").string(), "--cuts",
                                 (cli::kModelsDir / "hmmwv14.cuts.xml").string(), "-o", "s.cpp", "--graph", "g.dot",
                                 "--sparsity", "p.svg"},
                                dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(cli::slurp(dir / "g.dot").find("digraph mechanism"), std::string::npos);
  EXPECT_NE(cli::slurp(dir / "p.svg").find("<svg"), std::string::npos);
  const auto svg = cli::run_jrgen({(cli::kModelsDir / "arm7.urdf").string(), "-o", "t.cpp", "--graph", "g.svg"},
                                  dir.path());
  ASSERT_EQ(svg.status, 0) << svg.err << " (Graphviz's dot must be installed: scripts/install_dependencies.sh)";
  EXPECT_NE(cli::slurp(dir / "g.svg").find("<svg"), std::string::npos);
}

TEST(GraphCli, BadExtensionOrClashWritesNothing) {
  cli::ScratchDir dir("jrgen_graph");
  const std::string model = (cli::kModelsDir / "arm7.urdf").string();
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{model, "-o", "s.cpp", "--graph", "g.png"},
        std::vector<std::string>{model, "-o", "s.cpp", "--sparsity", "p.dot"},
        std::vector<std::string>{model, "-o", "s.cpp", "--graph", "p.svg", "--sparsity", "p.svg"}}) {
    const auto r = cli::run_jrgen(args, dir.path());
    EXPECT_EQ(r.status, 1) << r.command;  // an error in the options (docs/cli.md)
    EXPECT_EQ(count(r.err, "\n"), 1U) << r.err;
    EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << r.command;
  }
}

}  // namespace
