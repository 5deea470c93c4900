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
  jr::BodyState* workspace() { return workspace_.get(); }

 private:
  std::vector<jr::BodyModel> bodies_;
  std::vector<std::int32_t> dof_parent_, dof_user_, col_start_;
  std::unique_ptr<jr::BodyState[]> workspace_;
  jr::Model model_{};
};

/// Fills a BodyModel from a topology body (the emitter prints the same fields).
jr::BodyModel body_model(const topology::Body& body);

}  // namespace jrgen::analysis
