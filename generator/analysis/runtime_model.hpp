// The runtime's view of a topology::Tree, built in memory: the same tables the
// emitter writes into generated code, owned by one object.  Used for numeric
// checks at generation time and by tests that drive the runtime directly.
#pragma once

#include <jrgen/runtime.hpp>

#include <memory>
#include <vector>

#include "topology/topology.hpp"

namespace jrgen::analysis {

class RuntimeModel {
 public:
  RuntimeModel(const topology::Tree& tree, const Eigen::Vector3d& gravity);
  RuntimeModel(const RuntimeModel&) = delete;
  RuntimeModel& operator=(const RuntimeModel&) = delete;

  const jr::Model& model() const { return model_; }
  const jr::ConstraintModel& constraints() const { return constraints_; }
  /// The force elements (section 2b); empty tables when the model has none.
  const jr::ForceModel& forces() const { return forces_; }
  jr::BodyState* workspace() { return workspace_.get(); }
  jr::BodyMotion* motion() { return motion_.get(); }

 private:
  std::vector<jr::BodyModel> bodies_;
  std::vector<std::int32_t> dof_parent_, dof_user_, col_start_;
  std::vector<jr::CutModel> cuts_;
  std::vector<jr::SpringModel> springs_;
  std::vector<jr::JointForceModel> joint_forces_;
  std::unique_ptr<jr::BodyState[]> workspace_;
  std::unique_ptr<jr::BodyMotion[]> motion_;
  jr::Model model_{};
  jr::ConstraintModel constraints_{};
  jr::ForceModel forces_{};
};

/// Fills a BodyModel from a topology body (the emitter prints the same fields).
jr::BodyModel body_model(const topology::Body& body);

/// Fills the CutModel of every cut: kept-row masks, first rows and packed
/// Jacobian offsets follow the cuts' kept_rows (the emitter prints the same).
std::vector<jr::CutModel> cut_models(const topology::Tree& tree);

/// The springs, and the bodies with a joint spring's stiffness or a joint
/// force, in Lemma 2 order (the emitter prints the same tables).
std::vector<jr::SpringModel> spring_models(const topology::Tree& tree);
std::vector<jr::JointForceModel> joint_force_models(const topology::Tree& tree);

}  // namespace jrgen::analysis
