#pragma once
// GoogleTest fixtures of the sim tests whose tests share one scene or one
// navmesh, built once per suite (building them per test would dominate the
// suites' run time).

#include <gtest/gtest.h>

#include <memory>

#include "common/Check.h"
#include "sim/Agent.h"
#include "sim/NavMesh.h"
#include "sim/Scene.h"

namespace vln::test {

/// The navmesh of `MakeMesh()` with the default NavMeshConfig, shared by a
/// suite's tests.
template <sim::TriangleMesh (*MakeMesh)()>
class NavMeshSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    navmesh_ = sim::NavMesh::build(MakeMesh(), sim::NavMeshConfig{});
  }
  static void TearDownTestSuite() { navmesh_.reset(); }
  static const sim::NavMesh& navmesh() { return *navmesh_; }
  /// An agent standing (snapped to the navmesh) at (x, z) with `heading`
  /// radians.
  static sim::AgentState standing(float x, float z, float heading) {
    const auto p = navmesh().snapPoint({x, 0.0f, z});
    VLN_ASSERT(p.has_value());
    return {*p, heading};
  }

 private:
  static inline std::unique_ptr<sim::NavMesh> navmesh_;
};

/// The scene `MakeScene()`, shared by a suite's tests as `scene_`.
template <std::shared_ptr<const sim::Scene> (*MakeScene)()>
class SceneSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { scene_ = MakeScene(); }
  static void TearDownTestSuite() { scene_.reset(); }
  static inline std::shared_ptr<const sim::Scene> scene_;
};

}  // namespace vln::test
