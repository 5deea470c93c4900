// Assembly of closed loops (generator/analysis/constraints.cpp; docs/assembly.md;
// issue 19, items 3 and 9).
//
//   AssemblyDrawn      loops drawn open at a singular configuration (four-bars
//                      stretched, folded, collinear; a slider-crank in line; five
//                      coupled four-bars folded flat) assemble: the configuration
//                      jrgen uses closes every loop, checked by an independent
//                      formulation (reference link poses and the definitions of
//                      docs/interface.md section 2, not the runtime's Phi).
//   AssemblyModels     every loop model case (the project's models, trains,
//                      random trees with random cuts), assembled as drawn, keeps
//                      the zero configuration, with no assembly note.
//   AssemblyUnits      the same mechanisms drawn in millimetres and kilometres
//                      assemble to the same angles and keep the same rows.
//   AssemblyStart      --assemble-from: its start is used; bad files are one error.
//   AssemblyFails      a loop no configuration closes stays an error naming the
//                      loop joint, what was tried and --assemble-from.
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "analysis/constraints.hpp"
#include "common/model_cases.hpp"
#include "ir/error.hpp"
#include "reference/reference_dynamics.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = JRGEN_SOURCE_DIR;
const fs::path kAssemblyDir = kSource / "tests" / "assembly";

ir::Robot read(const fs::path& urdf, const fs::path& cuts = {}) {
  ir::Robot robot = urdf::read_robot(urdf.string());
  if (!cuts.empty()) urdf::read_cuts(cuts.string(), robot);
  return robot;
}

// Every length of the model times s (joint and cut frames, distances, centres
// of mass; inertias times s^2): the same mechanism in other units.
ir::Robot scaled(ir::Robot robot, double s) {
  for (ir::Joint& j : robot.joints) j.origin.p *= s;
  for (ir::Link& l : robot.links) {
    l.inertial.com *= s;
    l.inertial.I_com *= s * s;
  }
  for (ir::CutJoint& c : robot.cuts) {
    c.frame_k.p *= s;
    c.frame_l.p *= s;
    c.distance *= s;
  }
  return robot;
}

// The largest violation of a cut's definition (docs/interface.md section 2) at q,
// from the reference's link poses: lengths divided by `length`, angles as the
// sine of the misalignment.  Independent of the runtime's rows.
double closure_error(const ir::Robot& robot, const ir::CutJoint& cut, const Eigen::VectorXd& q, double length,
                     double distance) {
  const std::vector<reference::LinkPose> poses = reference::link_poses(robot, q);
  const reference::LinkPose& k = poses[cut.link_k];
  const reference::LinkPose& l = poses[cut.link_l];
  const Eigen::Matrix3d R_k = k.R_WL * cut.frame_k.R, R_l = l.R_WL * cut.frame_l.R;
  const Eigen::Vector3d d = (l.p_WL + l.R_WL * cut.frame_l.p - k.p_WL - k.R_WL * cut.frame_k.p) / length;
  const Eigen::Vector3d a_k = R_k * cut.axis, a_l = R_l * cut.axis;
  const double across = (d - a_k * a_k.dot(d)).norm();  // offset across the axis
  const double aligned = a_k.cross(a_l).norm();
  const double orientation = (R_k - R_l).norm();
  switch (cut.type) {
    case ir::CutType::Spherical: return d.norm();
    case ir::CutType::Revolute: return std::max(d.norm(), aligned);
    case ir::CutType::Prismatic: return std::max(across, orientation);
    case ir::CutType::Cylindrical: return std::max(across, aligned);
    case ir::CutType::Universal: return std::max(d.norm(), std::abs(a_k.dot(R_l * cut.child_axis)));
    case ir::CutType::Fixed: return std::max(d.norm(), orientation);
    case ir::CutType::Distance: return std::abs(d.norm() - distance / length);
    case ir::CutType::Mimic: break;  // not a frame constraint
  }
  return INFINITY;
}

// The closure conditions of the planar drawings' cuts as a vector (revolute:
// the gap d, then a_k x a_l; distance: |d| - D), from the reference's link
// poses, lengths over `length`.
Eigen::VectorXd closure_vector(const ir::Robot& robot, const Eigen::VectorXd& q, double length,
                               const std::vector<double>& distances) {
  const std::vector<reference::LinkPose> poses = reference::link_poses(robot, q);
  std::vector<double> out;
  for (std::size_t c = 0; c < robot.cuts.size(); ++c) {
    const ir::CutJoint& cut = robot.cuts[c];
    const reference::LinkPose& k = poses[cut.link_k];
    const reference::LinkPose& l = poses[cut.link_l];
    const Eigen::Vector3d d = (l.p_WL + l.R_WL * cut.frame_l.p - k.p_WL - k.R_WL * cut.frame_k.p) / length;
    const Eigen::Vector3d w = (k.R_WL * cut.frame_k.R * cut.axis).cross(l.R_WL * cut.frame_l.R * cut.axis);
    if (cut.type == ir::CutType::Distance) out.push_back(d.norm() - distances[c] / length);
    else if (cut.type == ir::CutType::Revolute) out.insert(out.end(), {d.x(), d.y(), d.z(), w.x(), w.y(), w.z()});
    else ADD_FAILURE() << "closure_vector: only revolute and distance cuts";
  }
  return Eigen::Map<const Eigen::VectorXd>(out.data(), static_cast<Eigen::Index>(out.size()));
}

// Singular values of the Jacobian of closure_vector at q (central
// differences in every joint coordinate: the drawings have only revolute and
// prismatic joints; step 1e-5, truncation error ~1e-10, far below the 1e-4
// relative gap the callers test).
Eigen::VectorXd closure_singular_values(const ir::Robot& robot, const Eigen::VectorXd& q, double length,
                                        const std::vector<double>& distances) {
  const double h = 1e-5;
  const Eigen::Index m = closure_vector(robot, q, length, distances).size();
  Eigen::MatrixXd J(m, q.size());
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    Eigen::VectorXd qp = q, qm = q;
    qp[i] += h;
    qm[i] -= h;
    J.col(i) = (closure_vector(robot, qp, length, distances) - closure_vector(robot, qm, length, distances)) / (2 * h);
  }
  return Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues();
}

struct Assembled {
  ir::Robot robot;
  topology::Tree tree;
  analysis::ConstraintAnalysis analysis;
  double length = 1.0;
  double drawn_error = 0.0;      ///< largest closure error at the zero configuration
  double assembled_error = 0.0;  ///< at the configuration jrgen uses
};

Assembled assemble(ir::Robot robot, const std::string& start_file = "") {
  Assembled a;
  a.robot = std::move(robot);
  a.tree = topology::build_tree(a.robot);
  a.analysis = analysis::analyze_constraints(a.robot, a.tree, /*strict=*/false, start_file);
  a.length = analysis::model_length_scale(a.tree);
  const Eigen::VectorXd q0 = reference::neutral_configuration(a.robot);
  for (std::size_t c = 0; c < a.robot.cuts.size(); ++c) {
    const double D = a.tree.cuts[c].distance;  // default distances are filled in by the analysis
    a.drawn_error = std::max(a.drawn_error, closure_error(a.robot, a.robot.cuts[c], q0, a.length, D));
    a.assembled_error = std::max(
        a.assembled_error, closure_error(a.robot, a.robot.cuts[c], a.analysis.configurations.front(), a.length, D));
  }
  return a;
}

// Assembly stops when max |phi~| < 1e-12 and accepts a start below 1e-9
// (relative to the length scale on length rows; constraints.cpp, kAssembled);
// the reference recomputes the closure with its own rounding, a few eps per joint.
constexpr double kClosed = 1e-9;

// ---- AssemblyDrawn --------------------------------------------------------------

class AssemblyDrawn : public ::testing::TestWithParam<const char*> {};

TEST_P(AssemblyDrawn, ClosesEveryLoop) {
  const fs::path urdf = kAssemblyDir / (std::string(GetParam()) + ".urdf");
  const Assembled a = assemble(read(urdf));
  // The drawing is open (so the test needs assembly) ...
  EXPECT_GT(a.drawn_error, 0.1) << urdf;
  // ... and the configuration used closes every loop.
  EXPECT_LT(a.assembled_error, kClosed) << urdf;
  // Which start assembled, the residuals and q (nq numbers) are said once.
  ASSERT_FALSE(a.analysis.notes.empty());
  const std::string& note = a.analysis.notes.front();
  EXPECT_NE(note.find(urdf.string() + ": the loops are open at the zero configuration"), std::string::npos) << note;
  EXPECT_NE(note.find("assembled from seeded start"), std::string::npos) << note;
  EXPECT_NE(note.find("--assemble-from"), std::string::npos) << note;
  EXPECT_NE(a.analysis.report_section.find("## Assembly"), std::string::npos);
  // Every cut keeps its two in-plane rows (all of these are planar) ...
  std::size_t kept = 0;
  std::vector<double> distances;
  for (const topology::Cut& cut : a.tree.cuts) {
    EXPECT_EQ(cut.kept_rows.size(), cut.type == ir::CutType::Distance ? 1u : 2u) << cut.name;
    kept += cut.kept_rows.size();
    distances.push_back(cut.distance);
  }
  // ... and the configuration used is regular: the closure Jacobian has that
  // many singular values above 1e-4 of the largest (jrgen prefers a regular
  // assembly; at the drawing, every one of these has a zero singular value).
  const Eigen::VectorXd sigma =
      closure_singular_values(a.robot, a.analysis.configurations.front(), a.length, distances);
  ASSERT_GE(sigma.size(), static_cast<Eigen::Index>(kept));
  EXPECT_GT(sigma[kept - 1], 1e-4 * sigma[0]) << sigma.transpose();
  if (sigma.size() > static_cast<Eigen::Index>(kept)) EXPECT_LT(sigma[kept], 1e-8 * sigma[0]) << sigma.transpose();
  const Eigen::VectorXd drawn_sigma =
      closure_singular_values(a.robot, reference::neutral_configuration(a.robot), a.length, distances);
  EXPECT_LE(drawn_sigma[kept - 1], 1e-8 * drawn_sigma[0]) << drawn_sigma.transpose();
  EXPECT_EQ(note.find("singular configuration"), std::string::npos) << note;
  // Deterministic: a second run gives the same configuration, bit for bit.
  const Assembled b = assemble(read(urdf));
  EXPECT_EQ(a.analysis.configurations.front(), b.analysis.configurations.front());
  EXPECT_EQ(a.analysis.notes, b.analysis.notes);
}

INSTANTIATE_TEST_SUITE_P(Singular, AssemblyDrawn,
                         ::testing::Values("fourbar_stretched", "fourbar_folded", "fourbar_collinear",
                                           "slider_crank_in_line", "nfourbar_folded"));

// ---- AssemblyModels ---------------------------------------------------------------

// Every loop model but Andrews' squeezer (models/andrews_squeezer.urdf), drawn with
// every angle 0 so that its coordinates are the IVP test set's angles: jrgen closes it
// (published_test starts it from the published angles).
TEST(AssemblyModels, AssembledDrawingsKeepTheZeroConfiguration) {
  for (const testing::ModelCase& c : testing::loop_models()) {
    if (c.name == "loops_andrews_squeezer") continue;
    SCOPED_TRACE(c.name);
    const Assembled a = assemble(testing::read_model_case(c));
    EXPECT_EQ(a.analysis.configurations.front(), reference::neutral_configuration(a.robot));
    EXPECT_LT(a.assembled_error, kClosed);
    EXPECT_EQ(a.analysis.report_section, "");
    for (const std::string& note : a.analysis.notes) EXPECT_EQ(note.find("assembled from"), std::string::npos);
    // Row selection used the assembly and both perturbed configurations.
    EXPECT_EQ(a.analysis.configurations.size(), 3u);
  }
}

// IFToMM A02 drawn flat: assembled but singular at q = 0.  The drawing is kept
// (as for every assembled drawing) and each cut keeps its two in-plane rows,
// found at the perturbed configurations.
TEST(AssemblyModels, FlatNFourbarKeepsItsDrawing) {
  const Assembled a = assemble(read(kAssemblyDir / "nfourbar_flat.urdf"));
  EXPECT_EQ(a.analysis.configurations.front(), reference::neutral_configuration(a.robot));
  EXPECT_LT(a.drawn_error, 1e-15);
  EXPECT_EQ(a.analysis.report_section, "");
  for (const topology::Cut& cut : a.tree.cuts) EXPECT_EQ(cut.kept_rows, (std::vector<int>{0, 1})) << cut.name;
}

// A drawing that is nearly closed (the four-bar's ground pivot moved 10 um)
// is closed from the zero configuration, and the note says the configuration
// used is not the drawing.
TEST(AssemblyModels, NearlyClosedDrawingIsClosedWithANote) {
  ir::Robot robot = read(kSource / "models" / "fourbar.urdf");
  robot.cuts[0].frame_l.p.x() += 1e-5;
  const Assembled a = assemble(robot);
  EXPECT_LT(a.assembled_error, kClosed);
  EXPECT_GT(a.drawn_error, 0.9e-5 / a.length);
  ASSERT_FALSE(a.analysis.notes.empty());
  EXPECT_NE(a.analysis.notes.front().find("the loops are open at the zero configuration (largest residual 1e-05, "
                                          "loop joint 'joint_D'); assembled from the zero configuration"),
            std::string::npos)
      << a.analysis.notes.front();
}

// ---- AssemblyUnits --------------------------------------------------------------

std::vector<std::vector<int>> kept_rows(const topology::Tree& tree) {
  std::vector<std::vector<int>> rows;
  for (const topology::Cut& cut : tree.cuts) rows.push_back(cut.kept_rows);
  return rows;
}

// The angles of two configurations of the same mechanism (translations
// divided by the length scale): the scaled problem is the same up to rounding,
// so Levenberg-Marquardt takes the same steps to within a few eps x its
// condition; 1e-8 leaves room for that over the iterations.
void expect_same_configuration(const Assembled& a, const Assembled& b) {
  Eigen::VectorXd qa = a.analysis.configurations.front(), qb = b.analysis.configurations.front();
  for (const topology::Body& body : a.tree.bodies) {
    const int translations = body.type == ir::JointType::Prismatic ? 1
                             : body.type == ir::JointType::Floating ? 3
                             : body.type == ir::JointType::Planar ? 2
                                                                  : 0;
    qa.segment(body.q_user, translations) /= a.length;
    qb.segment(body.q_user, translations) /= b.length;
  }
  EXPECT_LT((qa - qb).cwiseAbs().maxCoeff(), 1e-8) << qa.transpose() << "\n" << qb.transpose();
}

TEST(AssemblyUnits, StretchedFourbarInMillimetresAndKilometres) {
  const Assembled m = assemble(read(kAssemblyDir / "fourbar_stretched.urdf"));
  const std::pair<const char*, double> others[] = {{"fourbar_stretched_mm.urdf", 1e-3},
                                                   {"fourbar_stretched_km.urdf", 1e3}};
  for (const auto& [other, s] : others) {
    SCOPED_TRACE(other);
    const Assembled a = assemble(read(kAssemblyDir / other));
    EXPECT_LT(a.assembled_error, kClosed);
    EXPECT_EQ(kept_rows(a.tree), kept_rows(m.tree));
    expect_same_configuration(a, m);
    EXPECT_NEAR(a.length / m.length, s, 1e-15 * s);
  }
}

// Every loop model case and every singular drawing, scaled by 1e-3 and 1e3 in
// memory: the same rows and the same assembled angles as drawn.
TEST(AssemblyUnits, EveryModelAtThreeScales) {
  std::vector<ir::Robot> robots;
  for (const testing::ModelCase& c : testing::loop_models()) robots.push_back(testing::read_model_case(c));
  for (const char* name :
       {"fourbar_folded", "fourbar_collinear", "slider_crank_in_line", "nfourbar_folded", "nfourbar_flat"})
    robots.push_back(read(kAssemblyDir / (std::string(name) + ".urdf")));
  for (const ir::Robot& robot : robots) {
    const Assembled metres = assemble(robot);
    for (double s : {1e-3, 1e3}) {
      SCOPED_TRACE(robot.name + " x " + std::to_string(s));
      const Assembled a = assemble(scaled(robot, s));
      EXPECT_LT(a.assembled_error, kClosed);
      EXPECT_EQ(kept_rows(a.tree), kept_rows(metres.tree));
      expect_same_configuration(a, metres);
    }
  }
}

// ---- AssemblyStart (--assemble-from) -------------------------------------------

// ctest runs the tests of this file in parallel processes: every file name
// carries the test's name and the process id, so no two tests share a file.
fs::path unique_path(const std::string& name) {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  return fs::path(::testing::TempDir()) /
         ("assembly_test_" + std::string(test->name()) + "_" + std::to_string(::getpid()) + "_" + name);
}

struct TempFile {
  fs::path path;
  explicit TempFile(const std::string& text, const std::string& name = "q.txt")
      : path(unique_path(name)) {
    std::ofstream(path) << text;
  }
  ~TempFile() { fs::remove(path); }
};

// The stretched crank-rocker assembled by hand: crank at 90 degrees, B =
// (0, 0.4); C on the circle of radius 0.9 about D = (1.2, 0) at distance 1
// from B.  The file gives the three absolute link angles as joint angles.
Eigen::Vector3d hand_assembled_fourbar() {
  const Eigen::Vector2d B(0.0, 0.4), D(1.2, 0.0);
  const double b = 1.0, c = 0.9, e = (D - B).norm();
  const double along = (b * b - c * c + e * e) / (2.0 * e), up = std::sqrt(b * b - along * along);
  const Eigen::Vector2d u = (D - B) / e, n(-u.y(), u.x());
  const Eigen::Vector2d C = B + along * u + up * n;
  const double crank = M_PI / 2, coupler = std::atan2(C.y() - B.y(), C.x() - B.x());
  const double rocker = std::atan2(D.y() - C.y(), D.x() - C.x());
  return {crank, coupler - crank, rocker - coupler};
}

std::string numbers(const Eigen::VectorXd& q) {
  std::string text = "# joint_A joint_B, then joint_C\n";
  char buf[64];
  for (int i = 0; i < q.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.17g%s", q[i], i == 0 ? ", " : i == 1 ? "\n" : "\n");
    text += buf;
  }
  return text;
}

TEST(AssemblyStart, AnAssembledStartIsUsedAsGiven) {
  const Eigen::Vector3d q = hand_assembled_fourbar();
  const TempFile file(numbers(q));
  const Assembled a = assemble(read(kAssemblyDir / "fourbar_stretched.urdf"), file.path.string());
  // Closed to rounding already (max |phi~| < 1e-12): used as given.
  EXPECT_LT((a.analysis.configurations.front() - q).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT(a.assembled_error, kClosed);
  ASSERT_FALSE(a.analysis.notes.empty());
  EXPECT_NE(a.analysis.notes.front().find("assembled from the start in " + file.path.string()), std::string::npos)
      << a.analysis.notes.front();
}

// A start near one branch (the coupler above the ground) assembles on that
// branch, not on the one the seeded starts find.
TEST(AssemblyStart, TheStartChoosesTheBranch) {
  const Eigen::Vector3d q = hand_assembled_fourbar();
  const Eigen::Vector3d start = q + Eigen::Vector3d(0.05, -0.04, 0.03);
  const TempFile file(numbers(start));
  const Assembled a = assemble(read(kAssemblyDir / "fourbar_stretched.urdf"), file.path.string());
  EXPECT_LT(a.assembled_error, kClosed);
  // One degree of freedom: the crank may move, but the branch (sign of the
  // coupler and rocker angles) stays, within 0.1 rad of the hand assembly.
  EXPECT_LT((a.analysis.configurations.front() - q).cwiseAbs().maxCoeff(), 0.1)
      << a.analysis.configurations.front().transpose();
  const Assembled seeded = assemble(read(kAssemblyDir / "fourbar_stretched.urdf"));
  EXPECT_GT((seeded.analysis.configurations.front() - q).cwiseAbs().maxCoeff(), 0.1);
}

// A start that does not assemble (the stretched drawing itself, a stationary
// point) is followed by the zero configuration and the seeded starts; the note
// says so.
TEST(AssemblyStart, AFailedStartIsFollowedByTheOthers) {
  const TempFile file("0 0 0\n");
  const Assembled a = assemble(read(kAssemblyDir / "fourbar_stretched.urdf"), file.path.string());
  EXPECT_LT(a.assembled_error, kClosed);
  ASSERT_FALSE(a.analysis.notes.empty());
  EXPECT_NE(a.analysis.notes.front().find("; assembled from seeded start 1 of 16 (largest residual "),
            std::string::npos)
      << a.analysis.notes.front();
  EXPECT_NE(a.analysis.notes.front().find(" after the start in " + file.path.string() +
                                          " did not assemble (largest residual 1.1 from it)"),
            std::string::npos)
      << a.analysis.notes.front();
}

// One error line: the file, the line where known, what is wrong, what to give.
// A body on a ball joint, welded to the world by a fixed cut drawn a quarter
// turn open about z.  A start half a turn about x from the assembly makes the
// cut's three orientation rows vanish (reference_constraints_test,
// CutDefinitionResidual) with the frames apart: that start must not count
// as assembled (analysis/cut_definitions.hpp), and the one used must satisfy
// INTERFACE section 2's definition.
TEST(AssemblyStart, AStartWhereOnlyTheRowsCloseIsNotAnAssembly) {
  const TempFile urdf(R"(<robot name="weld">
  <link name="world"/>
  <link name="body"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="ball" type="ball"><parent link="world"/><child link="body"/></joint>
  <loop_joint name="weld" type="fixed">
    <parent link="body"/><child link="world"/><origin rpy="0 0 1.5707963267948966"/>
  </loop_joint>
</robot>)", "weld.urdf");
  // Assembled: the body turned -90 degrees about z.  Flipped: then half a turn
  // about the world's x axis, q = (0, s, s, 0) with s = sqrt(1/2).
  const double s = std::sqrt(0.5);
  const TempFile start(numbers((Eigen::VectorXd(4) << 0.0, s, s, 0.0).finished()));
  const Assembled a = assemble(read(urdf.path), start.path.string());
  ASSERT_FALSE(a.analysis.notes.empty());
  EXPECT_NE(a.analysis.notes.front().find("did not assemble"), std::string::npos) << a.analysis.notes.front();
  const Eigen::VectorXd& q = a.analysis.configurations.front();
  const Eigen::Quaterniond used(q[0], q[1], q[2], q[3]);
  const Eigen::Quaterniond assembled(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()));
  // The same rotation (q or -q): 1e-9 as the assembly tolerance.
  EXPECT_GT(std::abs(used.normalized().dot(assembled)), 1.0 - 1e-9) << q.transpose();
}

void expect_start_error(const std::string& text, const std::string& where, const std::string& what) {
  const TempFile file(text);
  const std::string path = file.path.string();
  try {
    assemble(read(kAssemblyDir / "fourbar_stretched.urdf"), path);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), path + where + ": " + what) << text;
  }
}

TEST(AssemblyStart, BadFilesAreOneError) {
  const std::string give = "give nq = 3 numbers (user order: joint_A, joint_B, joint_C)";
  expect_start_error("0.1 0.2\n", "", "has 2 numbers; " + give);
  expect_start_error("0.1, 0.2, 0.3, 0.4", "", "has 4 numbers; " + give);
  expect_start_error("", "", "has 0 numbers; " + give);
  expect_start_error("0.1\n0.2 x3\n0.3\n", ":2", "'x3' is not a finite number; " + give);
  expect_start_error("0.1 0.2 1e999\n", ":1", "'1e999' is not a finite number; " + give);
  expect_start_error("0.1 0.2 nan\n", ":1", "'nan' is not a finite number; " + give);
  expect_start_error("0.1;0.2;0.3\n", ":1", "'0.1;0.2;0.3' is not a finite number; " + give);
  const std::string missing = (fs::path(::testing::TempDir()) / "assembly_test_absent.txt").string();
  try {
    assemble(read(kAssemblyDir / "fourbar_stretched.urdf"), missing);
    ADD_FAILURE() << "no error for a missing file";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "--assemble-from " + missing +
                                         ": cannot read: No such file or directory; check the path (relative to "
                                         "the folder jrgen runs in)");
  }
  const std::string folder = ::testing::TempDir();
  try {
    assemble(read(kAssemblyDir / "fourbar_stretched.urdf"), folder);
    ADD_FAILURE() << "no error for a folder";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "--assemble-from " + folder + ": cannot read: it is a folder; give the file of nq numbers");
  }
}

// Quaternions in the start are normalized; an all-zero one is an error.  The
// HMMWV (a floating chassis, four ball joints) drawn assembled, given as its
// zero configuration with every quaternion scaled by 2: assembled at once.
TEST(AssemblyStart, QuaternionsAreNormalized) {
  const fs::path models = kSource / "models";
  const ir::Robot robot = read(models / "hmmwv14.urdf", models / "hmmwv14.cuts.xml");
  const topology::Tree tree = topology::build_tree(robot);
  const Eigen::VectorXd q0 = reference::neutral_configuration(robot);
  std::string text;
  for (int i = 0; i < q0.size(); ++i) text += std::to_string(2.0 * q0[i]) + (i % 4 == 3 ? "\n" : " ");
  {
    const TempFile file(text);
    const Assembled a = assemble(robot, file.path.string());
    EXPECT_EQ(a.analysis.configurations.front(), q0);
  }
  int at = -1;  // first coordinate of the floating joint's quaternion
  std::string joint;
  for (const topology::Body& b : tree.bodies)
    if (b.type == ir::JointType::Floating) {
      at = b.q_user + 3;
      joint = b.joint_name;
    }
  ASSERT_GE(at, 0);
  Eigen::VectorXd q = q0;
  q.segment<4>(at).setZero();
  std::string zero;
  for (int i = 0; i < q.size(); ++i) zero += std::to_string(q[i]) + "\n";
  const TempFile file(zero);
  try {
    assemble(robot, file.path.string());
    ADD_FAILURE() << "no error for a zero quaternion";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), file.path.string() + ": numbers " + std::to_string(at + 1) + " to " +
                                         std::to_string(at + 4) + " (the quaternion w x y z of joint '" + joint +
                                         "') are all 0; give a rotation");
  }
}

// ---- AssemblyFails ----------------------------------------------------------------

// A two-link arm of reach 1 m whose tip must reach 2 m: no start closes it.
TEST(AssemblyFails, InconsistentLoopIsAnErrorNamingWhatWasTried) {
  const fs::path urdf = kSource / "tests" / "cli" / "inconsistent_loop.urdf";
  for (bool with_start : {false, true}) {
    const TempFile file("0.3 -0.2\n");
    try {
      assemble(read(urdf), with_start ? file.path.string() : "");
      ADD_FAILURE() << "inconsistent_loop.urdf assembled";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(urdf.string() + ":", 0), 0u) << what;
      for (const char* part : {"<loop_joint> 'too_far': the loop cannot be closed", "16 seeded starts",
                               "residual of 1 here at best", "--assemble-from", "docs/assembly.md"})
        EXPECT_NE(what.find(part), std::string::npos) << part << "\n" << what;
      EXPECT_EQ(what.find("the start in") != std::string::npos, with_start) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace jrgen
