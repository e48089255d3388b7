#include "sim/MeshIo.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <string>

#include "common/Check.h"
#include "sim/GeometryCheck.h"
#include "sim/GlbWriter.h"
#include "sim/MeshImport.h"
#include "sim/ObjWriter.h"
#include "sim/SceneSemanticsFile.h"

namespace vln::sim {
namespace fs = std::filesystem;

namespace {

std::string lowerExtension(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

}  // namespace

LoadedScene loadScene(const fs::path& file, const MeshLoadConfig& config) {
  LoadedScene loaded;
  loaded.mesh = importMesh(file, config);
  // a file read with the wrong up axis loads fine and yields a wrong (or
  // no) navmesh: say so early
  if (const std::string hint = upAxisHint(loaded.mesh, config); !hint.empty())
    spdlog::warn("loadScene(): {}: {}", file.string(), hint);
  const fs::path sidecar = semanticsPath(file);
  if (fs::exists(sidecar)) loaded.semantics = loadSemantics(sidecar);
  return loaded;
}

void saveScene(const fs::path& file, const TriangleMesh& mesh,
               const SceneSemantics& semantics) {
  const std::string ext = lowerExtension(file);
  VLN_CHECK_ARG(ext == ".glb" || ext == ".obj", "saveScene(): ", file,
                ": unsupported extension '", ext, "' (use .glb or .obj)");
  mesh.validate(strCat("saveScene(): ", file.string()));
  if (ext == ".glb")
    writeGlb(file, mesh);
  else
    writeObj(file, mesh);
  // a sidecar left from an earlier scene of the same name would lie
  const fs::path sidecar = semanticsPath(file);
  if (!semantics.empty())
    saveSemantics(sidecar, semantics);
  else if (fs::exists(sidecar))
    fs::remove(sidecar);
}

}  // namespace vln::sim
