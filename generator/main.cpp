// jrgen command line (docs/interface.md section 1).  Parses options, runs the
// stages urdf -> topology -> emit, and reports any error as one line.
#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "analysis/constraints.hpp"
#include "analysis/finite_dynamics.hpp"
#include "emit/emitter.hpp"
#include "emit/graph.hpp"
#include "emit/report.hpp"
#include "ir/error.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage =
    "usage: jrgen MODEL.urdf [--cuts CUTS.xml] -o OUT.cpp [--namespace NAME]\n"
    "             [--gravity GX,GY,GZ] [--method llt|ldlt] [--report OPS.md]\n"
    "             [--strict-constraints] [--bound-mass KG] [--bound-inertia KGM2]\n"
    "             [--assemble-from Q.txt] [--singular off|proximal]\n"
    "             [--threads auto|1|N] [--divide] [--graph OUT.dot|OUT.svg]\n"
    "             [--sparsity OUT.svg]\n";

constexpr const char* kHelp =
    "Generates a loop-free C++ solver of the equations of motion of a mechanism\n"
    "(Negrut, Serban & Potra 1997): OUT.cpp and OUT.hpp.\n"
    "\n"
    "  MODEL.urdf            the spanning tree (URDF; type=\"ball\" joints and\n"
    "                        <loop_joint> elements accepted)\n"
    "  --cuts CUTS.xml       further cut joints (<loop_joints> root)\n"
    "  -o OUT.cpp            output; OUT.hpp is written beside it\n"
    "  --namespace NAME      C++ namespace (default: the robot name)\n"
    "  --gravity GX,GY,GZ    gravity in the world frame (default 0,0,-9.81;\n"
    "                        0,0,0 removes gravity code)\n"
    "  --method llt|ldlt     factorization: Cholesky or square-root-free L D L^T\n"
    "  --report OPS.md       write the operation counts of the emitted code\n"
    "  --graph OUT.dot|OUT.svg  draw the mechanism: bodies, tree joints, cut joints\n"
    "                        (dashed) and the Lemma 2 numbering (.svg needs Graphviz)\n"
    "  --sparsity OUT.svg    (extension) draw the patterns of L, T and T^T T\n"
    "  --strict-constraints  redundant constraint rows are an error\n"
    "  --bound-mass KG       raise every moving body lighter than KG to KG (one\n"
    "                        note each; MuJoCo's boundmass): loads links without\n"
    "                        <inertial>\n"
    "  --bound-inertia KGM2  raise every principal moment of inertia (about the\n"
    "                        centre of mass) below KGM2 to KGM2 (MuJoCo's\n"
    "                        boundinertia)\n"
    "  --assemble-from Q.txt start the assembly of the loops at Q.txt: nq numbers\n"
    "                        in user order, separated by spaces, newlines or\n"
    "                        commas (default: the zero configuration, then\n"
    "                        seeded starts; docs/assembly.md)\n"
    "  --threads auto|1|N    (extension) Corollary 3 parallel variant with OpenMP\n"
    "                        tasks over subtrees: auto (default) for large trees,\n"
    "                        1 never, N >= 2 always, with N threads\n"
    "  --divide              (extension) divide by each pivot where it is used, as\n"
    "                        the paper does, instead of multiplying by its\n"
    "                        reciprocal: one rounding per entry, a few % slower;\n"
    "                        steps that run the runtime's loops keep reciprocals\n"
    "  --singular off|proximal  (extension) at singular or redundant constraint\n"
    "                        rows: off (default) returns status 2; proximal\n"
    "                        solves for the minimum-norm lambda by a proximal-point\n"
    "                        iteration, returns 0 and sets last_solve_regularized()\n"
    "                        (docs/singular.md)\n"
    "  --help, --version\n"
    "\n"
    "Documentation: README.md and docs/ in the jrgen source tree (docs/cli.md: these\n"
    "options; docs/urdf.md, docs/coordinates.md, docs/api.md, docs/cmake.md).\n";

struct Arguments {
  std::string model;
  std::string cuts;
  std::string output;
  std::string name_space;
  bool namespace_given = false;
  std::string report;
  std::string graph;     ///< --graph: .dot or .svg
  std::string sparsity;  ///< --sparsity: .svg
  std::string assemble_from;
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  jrgen::emit::Method method = jrgen::emit::Method::kLLT;
  bool strict_constraints = false;
  int threads = 0;  ///< 0: auto
  bool divide = false;
  jrgen::topology::MassBounds bounds;
  bool singular_proximal = false;
};

// Every option and what its value looks like ("" for a flag), for "missing
// value" and "did you mean" messages.
const std::vector<std::pair<std::string, std::string>>& option_table() {
  static const std::vector<std::pair<std::string, std::string>> table = {
      {"-o", "OUT.cpp"},           {"--output", "OUT.cpp"},
      {"--cuts", "CUTS.xml"},      {"--namespace", "NAME"},
      {"--gravity", "GX,GY,GZ"},   {"--method", "llt|ldlt"},
      {"--report", "OPS.md"},      {"--graph", "OUT.dot|OUT.svg"},
      {"--sparsity", "OUT.svg"},   {"--assemble-from", "Q.txt"},
      {"--strict-constraints", ""}, {"--divide", ""},
      {"--bound-mass", "KG"},      {"--bound-inertia", "KGM2"},
      {"--singular", "off|proximal"}, {"--threads", "auto|1|N"},
      {"--help", ""},              {"--version", ""},
      {"-h", ""}};
  return table;
}

bool is_option(const std::string& a) {
  for (const auto& [name, metavar] : option_table())
    if (a == name) return true;
  return false;
}

// "unknown option" with what to write instead: "--method=ldlt" ->
// "--method ldlt"; a misspelling -> the option meant.
std::string unknown_option(const std::string& a) {
  const std::size_t eq = a.find('=');
  if (eq != std::string::npos && is_option(a.substr(0, eq)))
    return "unknown option '" + a + "'; write '" + a.substr(0, eq) + " " + a.substr(eq + 1) +
           "' (the value follows a space, not '=')";
  std::vector<std::string> names;
  for (const auto& [name, metavar] : option_table())
    if (name.size() > 2) names.push_back(name);
  const std::string near = jrgen::closest_match(a, names);
  if (!near.empty()) return "unknown option '" + a + "'; did you mean " + near + "? (see jrgen --help)";
  return "unknown option '" + a + "'; see jrgen --help for the options";
}

// `text` as a whole is one finite number.
bool parse_finite(const std::string& text, double& x) {
  std::size_t used = 0;
  try {
    x = std::stod(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used != 0 && used == text.size() && std::isfinite(x);
}

// The file of --graph or --sparsity: its extension says the format.
std::string picture_path(const std::string& option, const std::string& path, const std::vector<std::string>& allowed) {
  const std::string ext = fs::path(path).extension().string();
  for (const std::string& e : allowed)
    if (ext == e) return path;
  std::string list;
  for (const std::string& e : allowed) list += (list.empty() ? "" : " or ") + e;
  throw jrgen::Error(option + " '" + path + "': the file name must end in " + list + " (the format it writes)");
}

// A bound of --bound-mass or --bound-inertia: a finite number > 0.
double parse_bound(const std::string& option, const std::string& text) {
  double x = 0.0;
  if (!parse_finite(text, x) || !(x > 0.0))
    throw jrgen::Error(option + ": expected a positive number, got '" + text + "'; write e.g. " + option + " " +
                       (option == "--bound-mass" ? "1e-3" : "1e-6"));
  return x;
}

Eigen::Vector3d parse_gravity(const std::string& text) {
  Eigen::Vector3d g;
  std::size_t pos = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = text.find(',', pos);
    if ((k < 2) != (end != std::string::npos))
      throw jrgen::Error("--gravity: expected three numbers GX,GY,GZ, got '" + text +
                         "'; write them with commas and no spaces, e.g. --gravity 0,0,-9.81");
    const std::string part = text.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    if (!parse_finite(part, g[k]))
      throw jrgen::Error("--gravity: '" + part + "' is not a finite number; write e.g. --gravity 0,0,-9.81 (m/s^2)");
    pos = end + 1;
  }
  return g;
}

Arguments parse_arguments(int argc, char** argv) {
  Arguments args;
  auto value = [&](int& i) -> std::string {
    const std::string option = argv[i];
    std::string metavar;
    for (const auto& [name, m] : option_table())
      if (name == option) metavar = m;
    if (i + 1 >= argc) throw jrgen::Error(option + ": missing value; write " + option + " " + metavar);
    // "--cuts -o x.cpp": the value was forgotten, "-o" is not a file name.
    if (is_option(argv[i + 1]))
      throw jrgen::Error(option + ": missing value (the next argument, " + argv[i + 1] + ", is an option); write " +
                         option + " " + metavar);
    return argv[++i];
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-o" || a == "--output") args.output = value(i);
    else if (a == "--cuts") args.cuts = value(i);
    else if (a == "--namespace") {
      args.name_space = value(i);
      args.namespace_given = true;
    }
    else if (a == "--gravity") args.gravity = parse_gravity(value(i));
    else if (a == "--report") args.report = value(i);
    else if (a == "--graph") args.graph = picture_path(a, value(i), {".dot", ".svg"});
    else if (a == "--sparsity") args.sparsity = picture_path(a, value(i), {".svg"});
    else if (a == "--assemble-from") args.assemble_from = value(i);
    else if (a == "--strict-constraints") args.strict_constraints = true;
    else if (a == "--divide") args.divide = true;
    else if (a == "--bound-mass") args.bounds.mass = parse_bound(a, value(i));
    else if (a == "--bound-inertia") args.bounds.inertia = parse_bound(a, value(i));
    else if (a == "--singular") {
      const std::string m = value(i);
      if (m != "off" && m != "proximal")
        throw jrgen::Error("--singular: expected off or proximal, got '" + m + "' (docs/status.md)");
      args.singular_proximal = m == "proximal";
    }
    else if (a == "--threads") {
      const std::string t = value(i);
      if (t == "auto") {
        args.threads = 0;
      } else {
        std::size_t used = 0;
        int n = 0;
        try {
          n = std::stoi(t, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != t.size() || n < 1 || n > 1024)
          throw jrgen::Error("--threads: expected auto or a number of threads 1..1024, got '" + t + "'");
        args.threads = n;
      }
    } else if (a == "--method") {
      const std::string m = value(i);
      if (m == "llt") args.method = jrgen::emit::Method::kLLT;
      else if (m == "ldlt") args.method = jrgen::emit::Method::kLDLT;
      else throw jrgen::Error("--method: expected llt or ldlt, got '" + m + "'");
    } else if (!a.empty() && a[0] == '-') {
      throw jrgen::Error(unknown_option(a));
    } else if (args.model.empty()) {
      args.model = a;
    } else {
      throw jrgen::Error("more than one model given: '" + args.model + "' and '" + a + "'; give one MODEL.urdf" +
                         (fs::path(a).extension() == ".cpp" ? " (write -o before the output " + a + ")"
                                                            : " (further cut joints go in --cuts CUTS.xml)"));
    }
  }
  if (args.model.empty())
    throw jrgen::Error("missing MODEL.urdf: give the URDF file to generate from, e.g. jrgen robot.urdf -o robot.cpp");
  if (args.output.empty())
    throw jrgen::Error("missing -o OUT.cpp: say where to write the solver, e.g. jrgen " + args.model + " -o " +
                       fs::path(args.model).stem().string() + ".cpp");
  if (fs::path(args.output).extension() != ".cpp")
    throw jrgen::Error("-o " + args.output + ": the output must end in .cpp (OUT.hpp is written beside it); write -o " +
                       fs::path(args.output).replace_extension(".cpp").string());
  for (char c : fs::path(args.output).filename().string())
    if (c == '"' || c == '\\' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      throw jrgen::Error("-o: the output's file name may not hold quotes, backslashes or control characters, since the "
                         "solver #includes its header by that name; rename it");
  if (args.namespace_given) {
    const std::string why = jrgen::emit::invalid_namespace(args.name_space);
    if (!why.empty())
      throw jrgen::Error("--namespace '" + args.name_space + "': not usable as the solver's namespace: " + why +
                         "; give a name such as my_robot");
  }
  return args;
}

// Why `path` cannot be written, and what to do, for the option `role` gave
// it (-o, --report, ...): the folder is missing, is a file, or is not
// writable; else the system's reason `err`.
std::string cannot_write(const std::string& role, const fs::path& path, int err) {
  const fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  const std::string head = role + " " + path.string() + ": cannot write: ";
  std::error_code ec;
  if (fs::is_directory(path, ec))
    return head + "it is a folder; give the path of a file, or remove the folder";
  if (!fs::exists(folder, ec))
    return head + "the folder " + folder.string() + " does not exist; create it (mkdir -p " + folder.string() +
           ") or write elsewhere";
  if (!fs::is_directory(folder, ec)) return head + folder.string() + " is a file, not a folder; choose another path";
  if (err == EACCES || err == EPERM || err == EROFS)
    return head + std::strerror(err) + "; choose a folder you can write to, or change the permissions of " +
           folder.string();
  return head + std::strerror(err);
}

// Writes all files or none: each goes to a fresh temporary file in its
// folder first (mkstemp), every target is checked, then all are renamed into
// place.  A failure before the renames leaves no trace.
class AtomicOutput {
 public:
  void add(const std::string& role, const fs::path& path, const std::string& text) {
    std::error_code ec;
    if (fs::is_directory(path, ec)) throw jrgen::Error(cannot_write(role, path, EISDIR));
    std::string tmpl = path.string() + ".jrgen-tmp-XXXXXX";
    const int fd = ::mkstemp(tmpl.data());
    if (fd < 0) throw jrgen::Error(cannot_write(role, path, errno));
    pending_.push_back({fs::path(tmpl), path, role});
    std::FILE* f = ::fdopen(fd, "wb");
    if (f == nullptr) {
      const int err = errno;
      ::close(fd);
      throw jrgen::Error(cannot_write(role, path, err));
    }
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    const int saved = errno;
    if (std::fclose(f) != 0 || !ok)
      throw jrgen::Error(cannot_write(role, path, ok ? errno : saved));
    ::chmod(tmpl.c_str(), 0644);  // mkstemp makes 0600; outputs are ordinary files
  }
  void commit() {
    for (const auto& [tmp, path, role] : pending_) {
      std::error_code ec;
      if (fs::is_directory(path, ec)) throw jrgen::Error(cannot_write(role, path, EISDIR));
    }
    for (const auto& [tmp, path, role] : pending_) {
      std::error_code ec;
      fs::rename(tmp, path, ec);
      if (ec) throw jrgen::Error(cannot_write(role, path, ec.value()));
    }
    pending_.clear();
  }
  ~AtomicOutput() {
    for (const auto& [tmp, path, role] : pending_) {
      std::error_code ec;
      fs::remove(tmp, ec);
    }
  }

 private:
  struct Pending {
    fs::path tmp, path;
    std::string role;
  };
  std::vector<Pending> pending_;
};

// One file as the file system sees it: the (device, inode) pair of an
// existing path (symbolic links followed, so links and hard links to one file
// compare equal), else the lexically normal absolute path of a file still to
// be created (parent folders' links resolved).
struct FileIdentity {
  bool exists = false;
  dev_t device = 0;
  ino_t inode = 0;
  fs::path path;
  bool operator==(const FileIdentity& o) const {
    return exists == o.exists && (exists ? device == o.device && inode == o.inode : path == o.path);
  }
};

FileIdentity identify(const std::string& path) {
  FileIdentity id;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    id.exists = true;
    id.device = st.st_dev;
    id.inode = st.st_ino;
  } else {
    std::error_code ec;
    id.path = fs::weakly_canonical(fs::absolute(path), ec);
    if (ec) id.path = fs::absolute(path).lexically_normal();
  }
  return id;
}

struct NamedPath {
  std::string role;  ///< how the user gave it: "-o", "--report", "the model", ...
  std::string path;
};

// docs/interface.md section 1: no path jrgen writes may be one of its inputs or
// another of its outputs, compared as files (links and hard links included).
// Checked before anything is read or written.
void check_outputs_are_distinct(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const FileIdentity out = identify(outputs[i].path);
    auto clash = [&](const std::string& what, const std::string& path) {
      throw jrgen::Error(fmt::format("{} {}: that file is {} ({}); jrgen never writes over an input or two "
                                     "outputs into one file: choose another path",
                                     outputs[i].role, outputs[i].path, what, path));
    };
    for (const NamedPath& in : inputs)
      if (identify(in.path) == out) clash(in.role, in.path);
    for (std::size_t j = 0; j < i; ++j)
      if (identify(outputs[j].path) == out) clash("also written by " + outputs[j].role, outputs[j].path);
  }
}

int run(const Arguments& args) {
  {
    const fs::path hpp = fs::path(args.output).replace_extension(".hpp");
    std::vector<NamedPath> inputs = {{"the model", args.model}};
    if (!args.cuts.empty()) inputs.push_back({"the --cuts file", args.cuts});
    if (!args.assemble_from.empty()) inputs.push_back({"the --assemble-from file", args.assemble_from});
    std::vector<NamedPath> outputs = {{"-o", args.output}, {"the header of -o", hpp.string()}};
    if (!args.report.empty()) outputs.push_back({"--report", args.report});
    if (!args.graph.empty()) outputs.push_back({"--graph", args.graph});
    if (!args.sparsity.empty()) outputs.push_back({"--sparsity", args.sparsity});
    check_outputs_are_distinct(inputs, outputs);
  }
  jrgen::ir::Robot robot = jrgen::urdf::read_robot(args.model);
  if (!args.cuts.empty()) jrgen::urdf::read_cuts(args.cuts, robot);
  jrgen::topology::Tree tree;
  jrgen::analysis::ConstraintAnalysis analysis;
  try {
    tree = jrgen::topology::build_tree(robot, args.bounds);
    jrgen::analysis::check_finite_dynamics(robot, tree, args.gravity);
    // Closed loops: default distances, assembly, redundant rows (notes on stderr).
    analysis = jrgen::analysis::analyze_constraints(robot, tree, args.strict_constraints, args.assemble_from);
  } catch (const jrgen::Error& e) {
    // A misspelling the reader noted (<inertail>: no mass) often explains
    // the error; the one line names it.
    if (robot.notes.empty()) throw;
    std::string note = robot.notes.front();  // "file:line: <link> ...": the model's file goes without saying
    if (note.rfind(args.model + ":", 0) == 0) note = "of line " + note.substr(args.model.size() + 1);
    throw jrgen::Error(std::string(e.what()) + " (perhaps because " + note + ")");
  }

  const fs::path cpp_path(args.output);
  fs::path hpp_path = cpp_path;
  hpp_path.replace_extension(".hpp");
  jrgen::emit::Options options;
  options.name_space = args.namespace_given ? args.name_space : jrgen::emit::sanitize_identifier(robot.name);
  options.gravity = args.gravity;
  options.method = args.method;
  options.threads = args.threads;
  options.divide = args.divide;
  options.singular_proximal = args.singular_proximal;
  if (!analysis.configurations.empty()) {
    const Eigen::VectorXd& qa = analysis.configurations.front();
    options.q_assembled.assign(qa.data(), qa.data() + qa.size());
  }
  options.source_name = fs::path(args.model).filename().string();
  options.cuts_name = args.cuts.empty() ? "" : fs::path(args.cuts).filename().string();
  options.header_name = hpp_path.filename().string();
  const jrgen::emit::Solver solver = jrgen::emit::emit_solver(robot, tree, options);

  AtomicOutput out;
  out.add("-o", cpp_path, solver.source);
  out.add("the header of -o", hpp_path, solver.header);
  if (!args.report.empty())
    out.add("--report", args.report, jrgen::emit::operation_report(robot, tree, solver) + analysis.report_section);
  if (!args.graph.empty()) {
    const std::string dot = jrgen::emit::topology_dot(robot, tree);
    const bool svg = fs::path(args.graph).extension() == ".svg";
    out.add("--graph", args.graph, svg ? jrgen::emit::render_svg(dot, args.graph) : dot);
  }
  if (!args.sparsity.empty()) out.add("--sparsity", args.sparsity, jrgen::emit::sparsity_svg(robot, tree));
  out.commit();
  // Notes only after success: a failing run prints exactly one line.
  for (const std::string& note : robot.notes) std::cerr << "jrgen: note: " << note << '\n';
  for (const std::string& note : tree.notes) std::cerr << "jrgen: note: " << note << '\n';
  for (const std::string& note : analysis.notes) std::cerr << "jrgen: note: " << note << '\n';
  for (const std::string& note : solver.notes) std::cerr << "jrgen: note: " << note << '\n';
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage << '\n' << kHelp;
      return 0;
    }
    if (a == "--version") {
      std::cout << "jrgen " << JRGEN_VERSION << '\n';
      return 0;
    }
  }
  try {
    return run(parse_arguments(argc, argv));
  } catch (const jrgen::Error& e) {
    std::cerr << "jrgen: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "jrgen: internal error: " << e.what() << '\n';
    return 2;
  }
}
