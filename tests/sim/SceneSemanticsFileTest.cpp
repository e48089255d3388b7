#include "sim/SceneSemanticsFile.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "common/FileIo.h"
#include "sim/MeshIo.h"
#include "sim/SceneFileFixtures.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

namespace fs = std::filesystem;
using test::expectThrowWith;
using test::featureMesh;
using test::featureSemantics;

TEST(SceneSemanticsFileTest, SidecarWithAMissingFieldNamesFileAndField) {
  test::TempDir dir;
  const fs::path file = dir / "scene.glb";
  saveScene(file, featureMesh(), featureSemantics());
  auto root = nlohmann::json::parse(common::readFile(semanticsPath(file)));
  root["objects"][1].erase("category");
  test::writeText(semanticsPath(file), root.dump());
  expectThrowWith<std::invalid_argument>(
      [&] { loadScene(file, MeshLoadConfig{}); },
      {"scene.glb.semantics.json", "objects[1]",
       "field 'category' is missing"});
}

TEST(SceneSemanticsFileTest, SidecarWithAnUnknownRoomIsRejected) {
  test::TempDir dir;
  const fs::path sidecar = dir / "x.semantics.json";
  SceneSemantics semantics = featureSemantics();
  semantics.objects[0].room = 9;
  saveSemantics(sidecar, semantics);
  expectThrowWith<std::invalid_argument>([&] { loadSemantics(sidecar); },
                                         {"objects[0]", "room 9"});
}

TEST(SceneSemanticsFileTest, SidecarWithABadBoxIsRejected) {
  test::TempDir dir;
  const fs::path sidecar = dir / "x.semantics.json";
  saveSemantics(sidecar, featureSemantics());
  auto root = nlohmann::json::parse(common::readFile(sidecar));
  root["rooms"][0]["footprint"]["min"] = {1, 2, 3};
  test::writeText(sidecar, root.dump());
  expectThrowWith<std::invalid_argument>(
      [&] { loadSemantics(sidecar); },
      {"x.semantics.json", "rooms[0].footprint", "'min' needs 2 numbers"});
}

}  // namespace
}  // namespace vln::sim
