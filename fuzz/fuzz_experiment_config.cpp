// Fuzzes the strict YAML loader with the whole run config
// (train::loadExperimentConfig: yaml-cpp, _base_ includes relative to the
// file, every section's bounds and ExperimentConfig::validate()). A config
// it accepts must survive a round trip through its own YAML.
#include <optional>

#include "train/ExperimentConfig.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("run.yaml", data, size);
  std::optional<vln::train::ExperimentConfig> config;
  vln::fuzz::expectDocumentedErrors(
      [&] { config = vln::train::loadExperimentConfig(file); });
  if (!config) return 0;
  // an accepted config reads back equal from its resolved YAML; any
  // exception here is a finding too
  try {
    std::string yaml = vln::train::experimentConfigYaml(*config);
    auto again = vln::common::loadConfigText<vln::train::ExperimentConfig>(
        yaml, "round trip");
    if (!(again == *config)) {
      std::fprintf(stderr, "vln fuzz: config changed in a YAML round trip\n");
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vln fuzz: round trip of an accepted config: %s\n",
                 e.what());
    std::abort();
  }
  return 0;
}
