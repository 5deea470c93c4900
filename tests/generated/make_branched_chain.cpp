// make_branched_chain OUT.urdf: a branched tree with a long chain inside a
// branched part (the dense-supernode case of docs/benchmarks.md): a trunk of
// 3 revolute joints; on its top body three branches: (A) a 60-joint revolute
// chain ending in two 3-joint branches, (B) a ball joint and 5 revolute joints,
// (C) one prismatic joint.  In the dof tree, A's chain is one
// supernode of 60 dofs whose first dof has two children and whose panel holds
// the 3 trunk rows.  Deterministic (fixed parameters, no random numbers).
#include <cmath>
#include <cstdio>
#include <string>

namespace {

std::string text;
int count = 0;

void link(const std::string& name, double mass) {
  const double i = 0.01 + 0.002 * (count % 7);
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "  <link name=\"%s\"><inertial><origin xyz=\"0.05 0.01 0.12\"/><mass value=\"%.3f\"/>"
                "<inertia ixx=\"%.4f\" iyy=\"%.4f\" izz=\"%.4f\" ixy=\"0.001\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n",
                name.c_str(), mass, i, i * 1.3, i * 0.8);
  text += buf;
}

// A joint of `type` from parent to a new link; returns the new link's name.
std::string joint(const std::string& parent, const std::string& type) {
  const std::string child = "l" + std::to_string(++count);
  link(child, 0.5 + 0.1 * (count % 5));
  static const char* axes[] = {"1 0 0", "0 1 0", "0 0 1", "0.6 0.8 0"};
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "  <joint name=\"j%d\" type=\"%s\"><parent link=\"%s\"/><child link=\"%s\"/>"
                "<origin xyz=\"0.02 0.03 0.25\" rpy=\"0.1 0 0.2\"/><axis xyz=\"%s\"/>"
                "<limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/></joint>\n",
                count, type.c_str(), parent.c_str(), child.c_str(), axes[count % 4]);
  text += buf;
  return child;
}

std::string chain(std::string from, int n, const std::string& type = "revolute") {
  for (int k = 0; k < n; ++k) from = joint(from, type);
  return from;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_branched_chain OUT.urdf\n");
    return 2;
  }
  text = "<?xml version=\"1.0\"?>\n<robot name=\"branched_chain\">\n  <link name=\"world\"/>\n";
  const std::string top = chain("world", 3);
  const std::string end_a = chain(top, 60);
  chain(end_a, 3);
  chain(end_a, 3);
  chain(joint(top, "ball"), 5);
  chain(top, 1, "prismatic");
  text += "</robot>\n";
  std::FILE* f = std::fopen(argv[1], "w");
  if (f == nullptr || std::fputs(text.c_str(), f) < 0 || std::fclose(f) != 0) {
    std::fprintf(stderr, "make_branched_chain: cannot write %s\n", argv[1]);
    return 1;
  }
  return 0;
}
