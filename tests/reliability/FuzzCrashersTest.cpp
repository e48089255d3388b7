// Replays every input the fuzzers (fuzz/, scripts/fuzz.sh) found once
// crashing, kept under tests/data_files/crashers/<fuzz target>/, through the
// same reader as that target (fuzz_geometry: the same recipe runner,
// fuzz/GeometryFuzzing.h), and every committed seed under fuzz/corpus/.
// A crasher must now end in success or a documented exception
// (std::invalid_argument / std::runtime_error); when "<file>.expect" exists
// the error message must contain its first line. Seeds are valid files and
// must load.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <typeinfo>

#include "common/ZipIntegrity.h"
#include "data/Episode.h"
#include "data/Glove.h"
#include "data/GroundTruth.h"
#include "data/NavGraph.h"
#include "data/Npz.h"
#include "data/RxrEpisodes.h"
#include "data/SubInstructions.h"
#include "fuzz/GeometryFuzzing.h"
#include "sim/MeshIo.h"
#include "sim/NavMesh.h"
#include "support/TestPaths.h"
#include "train/Checkpoint.h"
#include "train/ExperimentConfig.h"

// Under LeakSanitizer: Debian's assimp 5.2 leaks the aiMesh it was filling
// when its OBJ/PLY parser throws (crashers/fuzz_mesh_*/assimp_leak.*); only
// allocations made inside libassimp are ignored. Unused without LSan.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }

namespace vln::reliability {
namespace {

namespace fs = std::filesystem;

std::string readBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path writeBytes(const fs::path& file, std::string_view bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  EXPECT_TRUE(out.good()) << file;
  return file;
}

// what one fuzz target does with its input (see fuzz/<target>.cpp): the
// input goes to a file of the same name in `dir`, then the reader runs and
// the target's extra invariants are checked (they throw std::logic_error,
// which is not a documented reader error, when violated)
using Reader = std::function<void(std::string_view input, const fs::path& dir)>;

// fuzz/MeshFuzzing.h: the input as scene.<extension>; a mesh that loads
// must be valid
Reader sceneReader(const std::string& extension) {
  return [extension](std::string_view in, const fs::path& dir) {
    auto scene =
        sim::loadScene(writeBytes(dir / ("scene." + extension), in), {});
    try {
      scene.mesh.validate("replay");
    } catch (const std::invalid_argument& e) {
      throw std::logic_error(
          std::string("loadScene returned an invalid mesh: ") + e.what());
    }
  };
}

const std::map<std::string, Reader>& readers() {
  static const std::map<std::string, Reader> table = {
      {"fuzz_experiment_config",
       [](std::string_view in, const fs::path& dir) {
         auto config = train::loadExperimentConfig(writeBytes(dir / "run.yaml", in));
         auto again = common::loadConfigText<train::ExperimentConfig>(
             train::experimentConfigYaml(config), "round trip");
         if (!(again == config))
           throw std::logic_error("config changed in a YAML round trip");
       }},
      {"fuzz_episodes",
       [](std::string_view in, const fs::path& dir) {
         data::readEpisodes(writeBytes(dir / "episodes.json.gz", in));
       }},
      {"fuzz_ground_truth",
       [](std::string_view in, const fs::path& dir) {
         data::readGroundTruth(writeBytes(dir / "split_gt.json.gz", in));
       }},
      {"fuzz_sub_instructions",
       [](std::string_view in, const fs::path& dir) {
         data::readSubInstructions(
             writeBytes(dir / "train_sub_instructions.json.gz", in));
       }},
      {"fuzz_glove_text",
       [](std::string_view in, const fs::path& dir) {
         if (in.empty()) return;
         data::GloveReadOptions options;
         if (in[0] & 1) options.dim = 3;
         if (in[0] & 2)
           options.only_words =
               std::unordered_set<std::string>{"the", ".", "a b"};
         auto vectors = data::readGloveText(writeBytes(dir / "glove.txt", in.substr(1)), options);
         for (int i = 0; i < vectors.size(); ++i)
           if (static_cast<int>(vectors.vector(i).size()) != vectors.dim())
             throw std::logic_error("ragged word vectors");
       }},
      {"fuzz_embeddings_json",
       [](std::string_view in, const fs::path& dir) {
         auto m = data::readEmbeddingsJson(writeBytes(dir / "embeddings.json.gz", in));
         if (static_cast<size_t>(m.rows) * static_cast<size_t>(m.dim) != m.values.size())
           throw std::logic_error("embedding matrix shape disagrees with its values");
       }},
      {"fuzz_mesh_obj", sceneReader("obj")},
      {"fuzz_mesh_ply", sceneReader("ply")},
      {"fuzz_navgraph",
       [](std::string_view in, const fs::path& dir) {
         auto graph = data::readNavGraph(writeBytes(dir / "graph.json", in));
         if (graph.numNodes() > 0) {
           const int last = graph.numNodes() - 1;
           (void)graph.shortestPath(0, last);
           (void)graph.nearestNode(graph.node(last).position);
         }
       }},
      {"fuzz_navmesh",
       [](std::string_view in, const fs::path& dir) {
         auto navmesh = sim::NavMesh::load(writeBytes(dir / "scene.navmesh", in));
         (void)navmesh->polygonCount();
         (void)navmesh->navigableArea();
         if (navmesh->islandCount() == 0) return;
         std::mt19937_64 rng(1);
         const Vec3f a = navmesh->randomPoint(rng);
         const Vec3f b = navmesh->randomPoint(rng);
         (void)navmesh->geodesicDistance(a, b);
         (void)navmesh->moveAlongSurface(a, b);
         (void)navmesh->distanceToObstacle(a);
         (void)navmesh->islandIndex(a);
       }},
      {"fuzz_geometry",
       [](std::string_view in, const fs::path& dir) {
         // documented errors of every stage, as one message for .expect
         fuzz::geometry::Report report;
         fuzz::geometry::runRecipe(in, dir, report);
         if (!report.errors.empty())
           throw std::invalid_argument(report.joined());
       }},
      {"fuzz_checkpoint",
       [](std::string_view in, const fs::path&) {
         (void)train::deserializeCheckpoint(in, "replay");
       }},
      {"fuzz_zip",
       [](std::string_view in, const fs::path&) {
         (void)common::verifyZipIntegrity(in, "replay");
       }},
      {"fuzz_rxr_episodes",
       [](std::string_view in, const fs::path& dir) {
         for (const auto& e : data::readRxrEpisodeFile(
                  writeBytes(dir / "train_guide.json.gz", in)))
           if (!e.instruction.instruction_id || e.instruction.language.empty())
             throw std::logic_error("an RxR episode without id or language");
       }},
      {"fuzz_npz",
       [](std::string_view in, const fs::path&) {
         for (const auto& [name, array] : data::parseNpz(
                  in, "replay", {.max_arrays = 64, .max_total_bytes = 1 << 24})) {
           uint64_t count = 1;
           for (int64_t dim : array.shape) count *= static_cast<uint64_t>(dim);
           if (count != array.values.size())
             throw std::logic_error("array '" + name + "' does not match its shape");
         }
       }},
  };
  return table;
}

// the files of dir/<target>/ (sidecars excluded), by target
std::map<std::string, std::vector<fs::path>> inputs(const fs::path& root) {
  std::map<std::string, std::vector<fs::path>> found;
  if (!fs::is_directory(root)) return found;
  for (const auto& targetDir : fs::directory_iterator(root)) {
    if (!targetDir.is_directory()) continue;
    auto& files = found[targetDir.path().filename().string()];
    for (const auto& entry : fs::directory_iterator(targetDir.path())) {
      const auto ext = entry.path().extension();
      if (entry.is_regular_file() && ext != ".expect" && ext != ".md") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
  }
  return found;
}

// "" when `file` was handled by `reader` as documented, else what went wrong;
// `message` receives the documented error's text
std::string replay(const Reader& reader, const fs::path& file, std::string* message) {
  vln::test::TempDir dir;
  try {
    reader(readBytes(file), dir.path());
  } catch (const std::invalid_argument& e) {
    *message = e.what();
  } catch (const std::runtime_error& e) {
    *message = e.what();
  } catch (const std::exception& e) {
    return strCat("undocumented exception ", typeid(e).name(), ": ", e.what());
  }
  return "";
}

TEST(FuzzCrashersTest, EveryCrasherEndsInADocumentedOutcome) {
  const fs::path root = vln::test::testDataPath() / "crashers";
  int replayed = 0;
  for (const auto& [target, files] : inputs(root)) {
    ASSERT_TRUE(readers().count(target)) << "crashers/" << target << " names no fuzz target";
    for (const auto& file : files) {
      SCOPED_TRACE(file.string());
      std::string message;
      EXPECT_EQ(replay(readers().at(target), file, &message), "");
      fs::path expect = file;
      expect += ".expect";
      if (fs::exists(expect)) {
        std::string wanted = readBytes(expect);
        wanted = wanted.substr(0, wanted.find('\n'));
        EXPECT_THAT(message, ::testing::HasSubstr(wanted));
      }
      ++replayed;
    }
  }
  RecordProperty("crashers", replayed);
}

TEST(FuzzCrashersTest, CommittedSeedsLoad) {
  const auto seeds = inputs(vln::test::sourcePath() / "fuzz" / "corpus");
  ASSERT_FALSE(seeds.empty()) << "fuzz/corpus is missing";
  for (const auto& [target, files] : seeds) {
    ASSERT_TRUE(readers().count(target)) << "fuzz/corpus/" << target << " names no fuzz target";
    for (const auto& file : files) {
      SCOPED_TRACE(file.string());
      std::string message;
      EXPECT_EQ(replay(readers().at(target), file, &message), "");
      EXPECT_EQ(message, "") << "a seed must be a valid file";
    }
  }
}

// the replay harness itself must see a reader's failure: an input that the
// episode reader rejects, and one that violates an extra invariant
TEST(FuzzCrashersTest, ReplayReportsUndocumentedFailures) {
  vln::test::TempDir dir;
  const fs::path bad = writeBytes(dir / "bad.json", "{\"episodes\": 3}");
  std::string message;
  EXPECT_EQ(replay(readers().at("fuzz_episodes"), bad, &message), "");
  EXPECT_THAT(message, ::testing::HasSubstr("episodes"));
  const Reader throwsLogic = [](std::string_view, const fs::path&) {
    throw std::out_of_range("index 7");
  };
  EXPECT_THAT(replay(throwsLogic, bad, &message), ::testing::HasSubstr("index 7"));
}

}  // namespace
}  // namespace vln::reliability
