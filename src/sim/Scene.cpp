#include "sim/Scene.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "common/Check.h"
#include "sim/GeometryCheck.h"
#include "sim/MeshIo.h"

namespace vln::sim {

namespace {

namespace fs = std::filesystem;

// A cached navmesh records the agent it was built for (Detour tile header);
// one built for another agent is stale even if it is newer than the scene.
// Values round-trip through float exactly, the margin only absorbs files
// written by other tools.
constexpr float kAgentMatchTolerance = 1e-4f;

bool sameAgent(const NavMeshConfig& a, const NavMeshConfig& b) {
  return std::abs(a.agent_height - b.agent_height) <= kAgentMatchTolerance &&
         std::abs(a.agent_radius - b.agent_radius) <= kAgentMatchTolerance &&
         std::abs(a.agent_max_climb - b.agent_max_climb) <=
             kAgentMatchTolerance;
}

// A navmesh's tiles span the x and z extent of the mesh it was built from
// and start at its lowest point (NavMesh::bounds()); a cache built from the
// same file read with another up axis or scale does not. The tolerance
// (1% of the mesh's largest extent + 1 cm) admits navmeshes of the same
// scene written by other tools.
bool builtForMesh(const Eigen::AlignedBox3f& navmesh,
                  const Eigen::AlignedBox3f& mesh) {
  const float tolerance = 0.01f * mesh.sizes().maxCoeff() + 0.01f;
  const Vec3f low = (navmesh.min() - mesh.min()).cwiseAbs();
  const Vec3f high = (navmesh.max() - mesh.max()).cwiseAbs();
  return low.maxCoeff() <= tolerance && high.x() <= tolerance &&
         high.z() <= tolerance;
}

// What a navmesh cache file held: a navmesh usable for this agent and mesh,
// or none, and whether the file is a sound one built for another agent
// (which is then kept, and this agent's navmesh cached beside it).
struct CachedNavMesh {
  std::unique_ptr<NavMesh> navmesh;
  bool otherAgent = false;
};

// The cached navmesh in `cacheFile` when it is present, at least as new as
// the scene, readable and built for this agent and mesh; none otherwise (with
// a log line when a present file is unusable).
CachedNavMesh loadCachedNavMesh(const fs::path& sceneFile,
                                const fs::path& cacheFile,
                                const NavMeshConfig& config,
                                const TriangleMesh& mesh) {
  std::error_code ec;
  if (!fs::exists(cacheFile, ec)) return {};
  const auto cacheTime = fs::last_write_time(cacheFile, ec);
  if (ec) return {};
  const auto sceneTime = fs::last_write_time(sceneFile, ec);
  if (ec || cacheTime < sceneTime) {
    spdlog::info("Scene: {} is older than the scene, rebuilding it",
                 cacheFile.string());
    return {};
  }
  try {
    auto navmesh = NavMesh::load(cacheFile);
    if (!sameAgent(navmesh->config(), config)) {
      spdlog::info(
          "Scene: {} was built for agent height {} radius {} climb {}, the "
          "config asks for {} {} {}; using the variant for this agent",
          cacheFile.string(), navmesh->config().agent_height,
          navmesh->config().agent_radius, navmesh->config().agent_max_climb,
          config.agent_height, config.agent_radius, config.agent_max_climb);
      return {nullptr, /*otherAgent=*/true};
    }
    if (!builtForMesh(navmesh->bounds(), mesh.bounds())) {
      spdlog::warn(
          "Scene: {} spans [{} {} {}] to [{} {} {}], the scene [{} {} {}] to "
          "[{} {} {}] (another up axis or scale?); rebuilding it",
          cacheFile.string(), navmesh->bounds().min().x(),
          navmesh->bounds().min().y(), navmesh->bounds().min().z(),
          navmesh->bounds().max().x(), navmesh->bounds().max().y(),
          navmesh->bounds().max().z(), mesh.bounds().min().x(),
          mesh.bounds().min().y(), mesh.bounds().min().z(),
          mesh.bounds().max().x(), mesh.bounds().max().y(),
          mesh.bounds().max().z());
      return {};
    }
    return {std::move(navmesh), false};
  } catch (const std::exception& e) {
    spdlog::warn("Scene: ignoring unusable navmesh cache: {}", e.what());
    return {};
  }
}

}  // namespace

std::filesystem::path navMeshVariantFile(const std::filesystem::path& sceneFile,
                                         const NavMeshConfig& config) {
  // millimetres: the tolerance sameAgent() allows is below one
  const auto mm = [](float metres) { return std::lround(metres * 1000.0f); };
  fs::path file = sceneFile;
  file +=
      strCat(".agent_r", mm(config.agent_radius), "_h", mm(config.agent_height),
             "_c", mm(config.agent_max_climb), ".navmesh");
  return file;
}

std::shared_ptr<const Scene> Scene::load(const std::filesystem::path& file,
                                         const SimConfig& config) {
  // mesh and semantics (loadScene names the file in its errors)
  LoadedScene loaded = loadScene(file, config.mesh);
  std::shared_ptr<Scene> scene(new Scene());
  scene->name_ = file.stem().string();
  scene->mesh_ = std::move(loaded.mesh);
  scene->semantics_ = std::move(loaded.semantics);

  // navmesh: the cache when it is valid, else the variant for this agent
  // when the cache holds another agent's, else a fresh build (saved when
  // caching; a read-only dataset directory only costs a rebuild next time)
  fs::path cacheFile = file;
  cacheFile += ".navmesh";
  if (config.cache_navmesh) {
    CachedNavMesh cached =
        loadCachedNavMesh(file, cacheFile, config.navmesh, scene->mesh_);
    if (cached.otherAgent) {
      cacheFile = navMeshVariantFile(file, config.navmesh);
      cached = loadCachedNavMesh(file, cacheFile, config.navmesh, scene->mesh_);
    }
    scene->navmesh_ = std::move(cached.navmesh);
  }
  if (scene->navmesh_ == nullptr) {
    try {
      scene->navmesh_ = NavMesh::build(scene->mesh_, config.navmesh);
    } catch (const std::invalid_argument& e) {
      // a mesh read with the wrong up axis is the usual cause
      const std::string hint = upAxisHint(scene->mesh_, config.mesh);
      throw std::invalid_argument(strCat("Scene::load(): ", file.string(), ": ",
                                         e.what(), hint.empty() ? "" : "; ",
                                         hint));
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(
          strCat("Scene::load(): ", file.string(), ": ", e.what()));
    }
    if (config.cache_navmesh) {
      try {
        scene->navmesh_->save(cacheFile);
      } catch (const std::exception& e) {
        spdlog::warn("Scene: cannot cache the navmesh: {}", e.what());
      }
    }
  }
  return scene;
}

std::shared_ptr<const Scene> Scene::fromMesh(std::string name,
                                             TriangleMesh mesh,
                                             SceneSemantics semantics,
                                             const NavMeshConfig& navmesh) {
  std::shared_ptr<Scene> scene(new Scene());
  scene->name_ = std::move(name);
  scene->mesh_ = std::move(mesh);
  scene->semantics_ = std::move(semantics);
  try {
    scene->navmesh_ = NavMesh::build(scene->mesh_, navmesh);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(
        strCat("Scene::fromMesh(): scene '", scene->name_, "': ", e.what()));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(
        strCat("Scene::fromMesh(): scene '", scene->name_, "': ", e.what()));
  }
  return scene;
}

const RayTracer& Scene::rayTracer() const {
  // built on first use: many consumers (navmesh-only training) never cast
  std::call_once(rayTracerOnce_,
                 [this] { rayTracer_ = std::make_unique<RayTracer>(mesh_); });
  return *rayTracer_;
}

}  // namespace vln::sim
