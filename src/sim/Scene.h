#pragma once
// The immutable part of a simulation: triangles, semantics, navmesh and ray
// tracing structure. Loaded once and shared (read-only) by every
// environment thread; per-episode state lives in EpisodeState.

#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include "sim/Mesh.h"
#include "sim/NavMesh.h"
#include "sim/RayTracer.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// The navmesh cache of `sceneFile` for an agent that the "<file>.navmesh"
/// cache was not built for: "<file>.agent_r<radius>_h<height>_c<climb>
/// .navmesh", dimensions in whole millimetres (e.g. RxR's
/// "x.glb.agent_r180_h880_c200.navmesh").
std::filesystem::path navMeshVariantFile(const std::filesystem::path& sceneFile,
                                         const NavMeshConfig& config);

class Scene {
 public:
  /// Loads a scene file (.glb/.gltf/.obj/.ply through assimp, see
  /// MeshIo.h) with its semantics sidecar if present, and its navmesh from
  /// "<file>.navmesh" when cache_navmesh and the file exists (building and
  /// saving it otherwise). A cache older than the scene file, unreadable or
  /// spanning other bounds than the mesh (the file read with another up
  /// axis or scale) is rebuilt and overwritten. A sound cache built for
  /// other agent dimensions (e.g. R2R's 0.1 m radius when RxR asks for
  /// 0.18 m) is kept: the navmesh comes from navMeshVariantFile() instead,
  /// under the same rules. Failing to write a cache (read-only dataset)
  /// only logs a warning. Throws naming the file on any other failure; a
  /// navmesh build error carries upAxisHint() (GeometryCheck.h) when the mesh
  /// looks read with the wrong up axis.
  static std::shared_ptr<const Scene> load(const std::filesystem::path& file,
                                           const SimConfig& config);
  /// Wraps an in-memory mesh (e.g. a generated house); builds its navmesh.
  static std::shared_ptr<const Scene> fromMesh(std::string name,
                                               TriangleMesh mesh,
                                               SceneSemantics semantics,
                                               const NavMeshConfig& navmesh);

  /// Scene name (file stem or the given name).
  const std::string& name() const { return name_; }
  const TriangleMesh& mesh() const { return mesh_; }
  const SceneSemantics& semantics() const { return semantics_; }
  const NavMesh& navmesh() const { return *navmesh_; }
  /// Embree BVH of mesh(), built on first use (thread-safe).
  const RayTracer& rayTracer() const;

 private:
  Scene() = default;
  std::string name_;
  TriangleMesh mesh_;
  SceneSemantics semantics_;
  std::unique_ptr<NavMesh> navmesh_;
  mutable std::once_flag rayTracerOnce_;
  mutable std::unique_ptr<RayTracer> rayTracer_;
};

}  // namespace vln::sim
