// jrgen command line (INTERFACE.md section 1).  Parses options, runs the
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
    "             [--threads auto|1|N] [--divide]\n";

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
    "  --help, --version\n";

struct Arguments {
  std::string model;
  std::string cuts;
  std::string output;
  std::string name_space;
  bool namespace_given = false;
  std::string report;
  std::string assemble_from;
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  jrgen::emit::Method method = jrgen::emit::Method::kLLT;
  bool strict_constraints = false;
  int threads = 0;  ///< 0: auto
  bool divide = false;
  jrgen::topology::MassBounds bounds;
  bool singular_proximal = false;
};

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

// A bound of --bound-mass or --bound-inertia: a finite number > 0.
double parse_bound(const std::string& option, const std::string& text) {
  double x = 0.0;
  if (!parse_finite(text, x) || !(x > 0.0))
    throw jrgen::Error(option + ": expected a positive number, got '" + text + "'");
  return x;
}

Eigen::Vector3d parse_gravity(const std::string& text) {
  Eigen::Vector3d g;
  std::size_t pos = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = text.find(',', pos);
    if ((k < 2) != (end != std::string::npos))
      throw jrgen::Error("--gravity: expected three numbers GX,GY,GZ, got '" + text + "'");
    const std::string part = text.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    if (!parse_finite(part, g[k]))
      throw jrgen::Error("--gravity: '" + part + "' is not a finite number");
    pos = end + 1;
  }
  return g;
}

Arguments parse_arguments(int argc, char** argv) {
  Arguments args;
  auto value = [&](int& i) -> std::string {
    if (i + 1 >= argc) throw jrgen::Error(std::string(argv[i]) + ": missing value");
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
    else if (a == "--assemble-from") args.assemble_from = value(i);
    else if (a == "--strict-constraints") args.strict_constraints = true;
    else if (a == "--divide") args.divide = true;
    else if (a == "--bound-mass") args.bounds.mass = parse_bound(a, value(i));
    else if (a == "--bound-inertia") args.bounds.inertia = parse_bound(a, value(i));
    else if (a == "--singular") {
      const std::string m = value(i);
      if (m != "off" && m != "proximal") throw jrgen::Error("--singular: expected off or proximal, got '" + m + "'");
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
      throw jrgen::Error("unknown option '" + a + "' (see jrgen --help)");
    } else if (args.model.empty()) {
      args.model = a;
    } else {
      throw jrgen::Error("more than one model given: '" + args.model + "' and '" + a + "'");
    }
  }
  if (args.model.empty()) throw jrgen::Error("missing MODEL.urdf (see jrgen --help)");
  if (args.output.empty()) throw jrgen::Error("missing -o OUT.cpp (see jrgen --help)");
  if (fs::path(args.output).extension() != ".cpp")
    throw jrgen::Error("-o " + args.output + ": the output must end in .cpp (OUT.hpp is written beside it)");
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

// Writes all files or none: each goes to a fresh temporary file in its
// folder first (mkstemp), every target is checked, then all are renamed into
// place.  A failure before the renames leaves no trace.
class AtomicOutput {
 public:
  void add(const fs::path& path, const std::string& text) {
    std::error_code ec;
    if (fs::is_directory(path, ec))
      throw jrgen::Error(path.string() + ": cannot write: Is a directory");
    std::string tmpl = path.string() + ".jrgen-tmp-XXXXXX";
    const int fd = ::mkstemp(tmpl.data());
    if (fd < 0) throw jrgen::Error(path.string() + ": cannot write: " + std::strerror(errno));
    pending_.push_back({fs::path(tmpl), path});
    std::FILE* f = ::fdopen(fd, "wb");
    if (f == nullptr) {
      ::close(fd);
      throw jrgen::Error(path.string() + ": cannot write: " + std::strerror(errno));
    }
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    const int saved = errno;
    if (std::fclose(f) != 0 || !ok)
      throw jrgen::Error(path.string() + ": cannot write: " + std::strerror(ok ? errno : saved));
    ::chmod(tmpl.c_str(), 0644);  // mkstemp makes 0600; outputs are ordinary files
  }
  void commit() {
    for (const auto& [tmp, path] : pending_) {
      std::error_code ec;
      if (fs::is_directory(path, ec)) throw jrgen::Error(path.string() + ": cannot write: Is a directory");
    }
    for (const auto& [tmp, path] : pending_) {
      std::error_code ec;
      fs::rename(tmp, path, ec);
      if (ec) throw jrgen::Error(path.string() + ": cannot write: " + ec.message());
    }
    pending_.clear();
  }
  ~AtomicOutput() {
    for (const auto& [tmp, path] : pending_) {
      std::error_code ec;
      fs::remove(tmp, ec);
    }
  }

 private:
  std::vector<std::pair<fs::path, fs::path>> pending_;
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

// INTERFACE.md section 1: no path jrgen writes may be one of its inputs or
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
    check_outputs_are_distinct(inputs, outputs);
  }
  jrgen::ir::Robot robot = jrgen::urdf::read_robot(args.model);
  if (!args.cuts.empty()) jrgen::urdf::read_cuts(args.cuts, robot);
  jrgen::topology::Tree tree = jrgen::topology::build_tree(robot, args.bounds);
  jrgen::analysis::check_finite_dynamics(robot, tree, args.gravity);
  // Closed loops: default distances, assembly, redundant rows (notes on stderr).
  const jrgen::analysis::ConstraintAnalysis analysis =
      jrgen::analysis::analyze_constraints(robot, tree, args.strict_constraints, args.assemble_from);

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
  out.add(cpp_path, solver.source);
  out.add(hpp_path, solver.header);
  if (!args.report.empty())
    out.add(args.report, jrgen::emit::operation_report(robot, tree, solver) + analysis.report_section);
  out.commit();
  // Notes only after success: a failing run prints exactly one line.
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
