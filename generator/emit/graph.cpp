#include "emit/graph.hpp"

#include <fmt/format.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "ir/error.hpp"

extern char** environ;

namespace jrgen::emit {

namespace {

// A DOT string literal's body: quotes and backslashes escaped, control
// characters as spaces (URDF names may hold anything).
std::string dot_escape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += static_cast<unsigned char>(c) < 0x20 ? ' ' : c;
  }
  return out;
}

// XML character data: the five entities, control characters as spaces.
std::string xml_escape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '&') out += "&amp;";
    else if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '"') out += "&quot;";
    else if (c == '\'') out += "&apos;";
    else out += static_cast<unsigned char>(c) < 0x20 ? ' ' : c;
  }
  return out;
}

// The names of the links carried, child link first; long lists shortened.
std::string link_list(const ir::Robot& robot, const std::vector<int>& links) {
  constexpr std::size_t kShown = 4;
  std::string out;
  for (std::size_t i = 0; i < links.size() && i < kShown; ++i)
    out += (i ? "\\n+ " : "") + dot_escape(robot.links[links[i]].name);
  if (links.size() > kShown) out += fmt::format("\\n+ {} more links", links.size() - kShown);
  return out;
}

std::string base_node(const ir::Robot& robot, const topology::Tree& tree) {
  std::vector<int> base_links;
  for (int l = 0; l < static_cast<int>(tree.links.size()); ++l)
    if (tree.links[l].body_lem < 0) base_links.push_back(l);
  return fmt::format("  base [shape=box, style=filled, fillcolor=\"#dddddd\", label=\"fixed base\\n{}\"];\n",
                     link_list(robot, base_links));
}

// Body i: its Lemma 2 number, its links, its dofs in Lemma 2 order.
std::string body_node(const ir::Robot& robot, const topology::Body& b, int i) {
  const std::string dofs = b.nv == 1 ? fmt::format("dof {}", b.v_lem)
                                     : fmt::format("dofs {}-{}", b.v_lem, b.v_lem + b.nv - 1);
  return fmt::format("  b{} [shape=ellipse, label=\"#{} {}\\n({})\"];\n", i, i, link_list(robot, b.links), dofs);
}

std::string node_name(int body_lem) { return body_lem < 0 ? "base" : fmt::format("b{}", body_lem); }

}  // namespace

std::string topology_dot(const ir::Robot& robot, const topology::Tree& tree) {
  std::string out = fmt::format(
      "// The topology of '{}' (jrgen --graph): bodies (links fused by fixed joints), tree joints\n"
      "// (solid, from parent to child) and cut joints (dashed). #i: the body's number in the Lemma 2\n"
      "// order (descendants before ancestors; Negrut, Serban & Potra 1997, Figures 3 and 4).\n"
      "digraph mechanism {{\n  rankdir=TB;\n  node [fontname=\"Helvetica\", fontsize=10];\n"
      "  edge [fontname=\"Helvetica\", fontsize=9];\n",
      one_line(robot.name));
  out += base_node(robot, tree);
  for (int i = 0; i < static_cast<int>(tree.bodies.size()); ++i) out += body_node(robot, tree.bodies[i], i);
  for (int i = 0; i < static_cast<int>(tree.bodies.size()); ++i) {
    const topology::Body& b = tree.bodies[i];
    out += fmt::format("  {} -> b{} [label=\"{}\\n{}\"];\n", node_name(b.parent_lem), i, dot_escape(b.joint_name),
                       ir::joint_type_name(b.type));
  }
  for (const topology::Cut& c : tree.cuts) {
    const std::size_t kept = c.kept_rows.size();
    const std::string rows = kept == static_cast<std::size_t>(c.rows) ? fmt::format("{} row{}", c.rows, c.rows == 1 ? "" : "s")
                                                                      : fmt::format("{} of {} rows", kept, c.rows);
    out += fmt::format(
        "  {} -> {} [style=dashed, color=\"#c0392b\", fontcolor=\"#c0392b\", dir=none, constraint=false, "
        "label=\"cut {}\\n{}, {}\"];\n",
        node_name(c.body_k), node_name(c.body_l), dot_escape(c.name), ir::cut_type_name(c.type), rows);
  }
  return out + "}\n";
}

namespace {

// Structural patterns in Lemma 2 order: L (column j: j and its ancestors,
// Lemma 2), T (the kept rows of cut c: the dofs of Lemma 3), T^T T (rows of
// cuts sharing a Lemma 3 dof, Remark 4).
struct Patterns {
  int nv = 0, nc = 0;
  std::vector<std::pair<int, int>> L, T, TT;  ///< (row, column)
};

Patterns patterns(const topology::Tree& tree) {
  Patterns p;
  p.nv = static_cast<int>(tree.dof_parent.size());
  for (int j = 0; j < p.nv; ++j)
    for (int i = j; i >= 0; i = tree.dof_parent[i]) p.L.emplace_back(i, j);
  std::vector<int> cut_of_row;
  for (int c = 0; c < static_cast<int>(tree.cuts.size()); ++c)
    for (std::size_t r = 0; r < tree.cuts[c].kept_rows.size(); ++r) {
      for (const int d : tree.cuts[c].dofs) p.T.emplace_back(d, static_cast<int>(cut_of_row.size()));
      cut_of_row.push_back(c);
    }
  p.nc = static_cast<int>(cut_of_row.size());
  for (int r = 0; r < p.nc; ++r)
    for (int s = 0; s < p.nc; ++s) {
      const auto& a = tree.cuts[cut_of_row[r]].dofs;
      const auto& b = tree.cuts[cut_of_row[s]].dofs;
      std::vector<int> common;
      std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(common));
      if (!common.empty()) p.TT.emplace_back(r, s);
    }
  return p;
}

// One matrix panel at (x, y): a frame, a title and a square per entry.
std::string panel(double x, double y, double cell, int rows, int cols, const std::vector<std::pair<int, int>>& nz,
                  const std::string& title, const std::string& color) {
  std::string out = fmt::format("<g transform=\"translate({:.1f},{:.1f})\">\n", x, y);
  out += fmt::format("<text x=\"0\" y=\"-8\" font-size=\"13\">{}</text>\n", xml_escape(title));
  out += fmt::format("<rect x=\"0\" y=\"0\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"white\" stroke=\"#444\"/>\n",
                     cols * cell, rows * cell);
  for (const auto& [i, j] : nz)
    out += fmt::format("<rect x=\"{:.2f}\" y=\"{:.2f}\" width=\"{:.2f}\" height=\"{:.2f}\" fill=\"{}\"/>\n", j * cell,
                       i * cell, cell, cell, color);
  return out + "</g>\n";
}

}  // namespace

std::string sparsity_svg(const ir::Robot& robot, const topology::Tree& tree) {
  const Patterns p = patterns(tree);
  const int largest = std::max(p.nv, p.nc);
  const double cell = std::clamp(360.0 / std::max(largest, 1), 1.0, 14.0);
  const double margin = 30.0, gap = 40.0, top = 60.0;
  const double wL = p.nv * cell, wT = p.nc * cell;
  const double width = margin * 2 + wL + (p.nc > 0 ? 2 * gap + wT + wT : 0.0);
  const double height = top + std::max(wL, wT) + margin;
  std::string out = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0f}\" height=\"{:.0f}\" "
      "font-family=\"Helvetica, Arial, sans-serif\" shape-rendering=\"crispEdges\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      "<text x=\"{:.0f}\" y=\"22\" font-size=\"14\">{}: structurally non-zero entries, Lemma 2 order "
      "(nv = {}, nc = {})</text>\n",
      width, height, margin, xml_escape(one_line(robot.name)), p.nv, p.nc);
  out += panel(margin, top, cell, p.nv, p.nv, p.L, fmt::format("L ({} entries, no fill-in: Lemma 2)", p.L.size()),
               "#1f4e79");
  if (p.nc > 0) {
    out += panel(margin + wL + gap, top, cell, p.nv, p.nc, p.T,
                 fmt::format("T = L^-1 Phiq^T ({}: Lemma 3)", p.T.size()), "#b35900");
    out += panel(margin + wL + 2 * gap + wT, top, cell, p.nc, p.nc, p.TT,
                 fmt::format("T^T T ({}: Remark 4)", p.TT.size()), "#2e7d32");
  }
  return out + "</svg>\n";
}

namespace {

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A fresh temporary path (mkstemp), removed when this object goes.
struct TempFile {
  std::filesystem::path path;
  explicit TempFile(const char* suffix) {
    std::string tmpl = (std::filesystem::temp_directory_path() / "jrgen-graph-XXXXXX").string() + suffix;
    const int fd = ::mkstemps(tmpl.data(), static_cast<int>(std::strlen(suffix)));
    if (fd < 0) throw Error(std::string("--graph: cannot create a temporary file: ") + std::strerror(errno));
    ::close(fd);
    path = tmpl;
  }
  ~TempFile() {
    std::error_code ec;
    std::filesystem::remove(path, ec);
  }
};

}  // namespace

std::string render_svg(const std::string& dot_text, const std::string& for_path) {
  const TempFile in(".dot"), out(".svg");
  std::ofstream(in.path, std::ios::binary) << dot_text;
  std::string a0 = "dot", a1 = "-Tsvg", a2 = "-o" + out.path.string(), a3 = in.path.string();
  char* argv[] = {a0.data(), a1.data(), a2.data(), a3.data(), nullptr};
  pid_t pid = 0;
  const std::string fix = fmt::format(
      "install Graphviz (apt-get install graphviz), or write DOT with --graph {}",
      std::filesystem::path(for_path).replace_extension(".dot").string());
  posix_spawn_file_actions_t quiet;  // dot's own messages would break jrgen's one-line errors
  ::posix_spawn_file_actions_init(&quiet);
  ::posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  const int spawned = ::posix_spawnp(&pid, "dot", &quiet, nullptr, argv, environ);
  ::posix_spawn_file_actions_destroy(&quiet);
  if (spawned != 0)
    throw Error(fmt::format("--graph {}: cannot run Graphviz's dot to render SVG; {}", for_path, fix));
  int status = 0;
  if (::waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error(fmt::format("--graph {}: Graphviz's dot failed to render SVG (status {}); {}", for_path,
                            WIFEXITED(status) ? WEXITSTATUS(status) : -1, fix));
  std::string svg = read_file(out.path);
  if (svg.empty()) throw Error(fmt::format("--graph {}: Graphviz's dot wrote nothing; {}", for_path, fix));
  return svg;
}

}  // namespace jrgen::emit
