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
  jr::BodyState* workspace() { return workspace_.get(); }
  jr::BodyMotion* motion() { return motion_.get(); }

 private:
  std::vector<jr::BodyModel> bodies_;
  std::vector<std::int32_t> dof_parent_, dof_user_, col_start_;
  std::vector<jr::CutModel> cuts_;
  std::unique_ptr<jr::BodyState[]> workspace_;
  std::unique_ptr<jr::BodyMotion[]> motion_;
  jr::Model model_{};
  jr::ConstraintModel constraints_{};
};

/// Fills a BodyModel from a topology body (the emitter prints the same fields).
jr::BodyModel body_model(const topology::Body& body);

/// Fills the CutModel of every cut: kept-row masks, first rows and packed
/// Jacobian offsets follow the cuts' kept_rows (the emitter prints the same).
std::vector<jr::CutModel> cut_models(const topology::Tree& tree);

}  // namespace jrgen::analysis
