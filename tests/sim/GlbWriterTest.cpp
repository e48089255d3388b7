#include "sim/GlbWriter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/FileIo.h"
#include "sim/MeshIo.h"
#include "sim/SceneFileFixtures.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

namespace fs = std::filesystem;
using test::featureMesh;

TEST(GlbWriterTest, GlbIsAValidContainer) {
  test::TempDir dir;
  const fs::path file = dir / "scene.glb";
  saveScene(file, featureMesh());
  const std::string bytes = common::readFile(file);
  ASSERT_GE(bytes.size(), 28u);
  auto u32 = [&](size_t offset) {
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | uint8_t(bytes[offset + i]);
    return v;
  };
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(u32(4), 2u);
  EXPECT_EQ(u32(8), bytes.size());
  const uint32_t jsonLength = u32(12);
  EXPECT_EQ(jsonLength % 4, 0u);
  EXPECT_EQ(bytes.substr(16, 4), "JSON");
  const auto root = nlohmann::json::parse(bytes.substr(20, jsonLength));
  const size_t binHeader = 20 + jsonLength;
  EXPECT_EQ(u32(binHeader) % 4, 0u);
  EXPECT_EQ(bytes.substr(binHeader + 4, 4), std::string("BIN\0", 4));
  EXPECT_EQ(binHeader + 8 + u32(binHeader), bytes.size());
  // node names carry the semantic ids; materials are unlit
  std::vector<std::string> names;
  for (const auto& node : root["nodes"]) names.push_back(node["name"]);
  EXPECT_THAT(names, ::testing::UnorderedElementsAre("structure", "object_3",
                                                     "object_12"));
  for (const auto& material : root["materials"])
    EXPECT_TRUE(material["extensions"].contains("KHR_materials_unlit"));
  EXPECT_EQ(root["images"][0]["mimeType"], "image/png");
  for (const auto& accessor : root["accessors"]) {
    if (accessor["type"] == "VEC3") {
      EXPECT_EQ(accessor["min"].size(), 3u);
    }
  }
}

}  // namespace
}  // namespace vln::sim
