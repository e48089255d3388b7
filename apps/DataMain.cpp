// vlnce-data: tools for R2R_VLNCE-format datasets. Each subcommand is one
// add*() function that declares its options on a CLI11 subcommand and
// returns the runner (a call into data/DataCommands.h or
// world/WorldCommands.h); adding a subcommand is one such function plus one
// line in main().

#include <CLI/CLI.hpp>

#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/App.h"
#include "common/Config.h"
#include "data/DataCommands.h"
#include "waypoint/WaypointCommands.h"
#include "world/WorldCommands.h"

namespace {

using namespace vln;

// a registered subcommand: its CLI11 node and what to run once parsed
struct Subcommand {
  CLI::App* command = nullptr;
  std::function<int()> run;
};

Subcommand addStats(CLI::App& app) {
  auto options = std::make_shared<data::StatsCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "stats", "Summary statistics of an episode file (real or generated)");
  command
      ->add_option("--episodes", options->episodes,
                   "Episode file {split}.json(.gz)")
      ->required()
      ->check(CLI::ExistingFile);
  command
      ->add_option("--gt", options->ground_truth,
                   "Ground truth {split}_gt.json(.gz) for action stats")
      ->check(CLI::ExistingFile);
  command->add_flag("--json", options->json, "Print JSON instead of text");
  return {command,
          [options] { return data::runStatsCommand(*options, std::cout); }};
}

Subcommand addGlove(CLI::App& app) {
  auto options = std::make_shared<data::GloveCommandOptions>();
  data::GloveFitConfig& fit = options->fit;
  CLI::App* command = app.add_subcommand(
      "glove", "Fit GloVe vectors on a corpus and write the text format");
  command
      ->add_option("--corpus", options->corpus,
                   "Episode file (.json/.json.gz) or text file, one "
                   "sentence per line")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out, "GloVe text file to write")
      ->required();
  command->add_option("--embeddings-out", options->embeddings_out,
                      "Also write embeddings.json(.gz) for a vocabulary");
  command
      ->add_option("--vocab-from", options->vocab_from,
                   "Episode file whose instruction_vocab gives the rows "
                   "of --embeddings-out")
      ->check(CLI::ExistingFile);
  // the hyper-parameters, documented as in the world config's glove: section
  data::GloveFitConfig defaults;
  const auto hyper = [&](const char* flag, auto& value, const char* key) {
    command
        ->add_option(flag, value,
                     common::configDoc(
                         [&](common::ConfigVisitor& v) { defaults.visit(v); },
                         key))
        ->capture_default_str();
  };
  hyper("--dim", fit.dim, "dim");
  hyper("--epochs", fit.epochs, "epochs");
  hyper("--window", fit.window, "window");
  hyper("--min-count", fit.min_count, "min_count");
  hyper("--x-max", fit.x_max, "x_max");
  hyper("--alpha", fit.alpha, "alpha");
  hyper("--lr", fit.learning_rate, "learning_rate");
  hyper("--grad-clip", fit.grad_clip, "grad_clip");
  hyper("--seed", fit.seed, "seed");
  hyper("--threads", fit.threads, "threads");
  return {command,
          [options] { return data::runGloveCommand(*options, std::cout); }};
}

Subcommand addEmbeddings(CLI::App& app) {
  auto options = std::make_shared<data::EmbeddingsCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "embeddings",
      "Build embeddings.json(.gz) for an episode file's vocabulary from "
      "GloVe vectors");
  command
      ->add_option("--glove", options->glove, "GloVe text file (plain or .gz)")
      ->required()
      ->check(CLI::ExistingFile);
  command
      ->add_option("--episodes", options->episodes,
                   "Episode file with instruction_vocab")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out, "embeddings.json(.gz) to write")
      ->required();
  const std::map<std::string, data::MissingWordPolicy> policies = {
      {"unk", data::MissingWordPolicy::kUnkRow},
      {"zero", data::MissingWordPolicy::kZero}};
  command
      ->add_option("--missing", options->missing,
                   "Row of words without a GloVe vector: unk or zero")
      ->transform(CLI::CheckedTransformer(policies, CLI::ignore_case));
  return {command, [options] {
            return data::runEmbeddingsCommand(*options, std::cout);
          }};
}

Subcommand addRxrMerge(CLI::App& app) {
  auto options = std::make_shared<data::RxrMergeCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "rxr-merge",
      "Merge RxR inference outputs (.jsonl, e.g. one per language) into one "
      "file sorted by instruction_id, refusing duplicates");
  command->add_option("inputs", options->inputs, "The .jsonl files to merge")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out, "Merged .jsonl to write")
      ->required();
  return {command,
          [options] { return data::runRxrMergeCommand(*options, std::cout); }};
}

Subcommand addGenerate(CLI::App& app) {
  auto options = std::make_shared<world::GenerateCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "generate",
      "Generate the procedural world: houses, nav-graphs, transferred "
      "trajectories, instructions and R2R splits; with an RxR config "
      "(configs/world/rxr.yaml) the RxR_VLNCE_v0 split of its houses");
  command->add_option("--out", options->out, "Dataset root to write")
      ->required();
  command->add_option("--config", options->config, "World config YAML")
      ->check(CLI::ExistingFile);
  command->add_option("--scenes-dir", options->scenes_dir,
                      "Root of the scene ids (houses go to <dir>/procedural)")
      ->capture_default_str();
  command->add_option("--houses", options->houses, "Number of houses");
  command->add_option("--seed", options->seed, "Master seed");
  command->add_option("--threads", options->threads, "Houses in parallel")
      ->capture_default_str();
  command->add_option("--set", options->overrides,
                      "Config override section.key=value (repeatable)");
  return {command,
          [options] { return world::runGenerateCommand(*options, std::cout); }};
}

Subcommand addTransfer(CLI::App& app) {
  auto options = std::make_shared<world::TransferCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "transfer",
      "Transfer a nav-graph onto a scene's navmesh (paper Section 3.2) and "
      "check the navigability of R2R-like trajectories");
  command->add_option("--graph", options->graph, "Nav-graph JSON")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--scene", options->scene, "Scene mesh file")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out,
                      "Write the transferred graph and statistics here");
  command->add_option("--config", options->config,
                      "World config YAML (navmesh, agent, trajectories, "
                      "transfer sections)")
      ->check(CLI::ExistingFile);
  command->add_option("--set", options->overrides,
                      "Config override section.key=value (repeatable)");
  command->add_option("--up-axis", options->up_axis, "Scene up axis: y or z")
      ->capture_default_str();
  command->add_option("--trajectories", options->trajectories,
                      "R2R-like trajectories to check")
      ->capture_default_str();
  command->add_option("--seed", options->seed, "Sampling seed")
      ->capture_default_str();
  command->add_flag("--json", options->json, "Print JSON instead of text");
  return {command,
          [options] { return world::runTransferCommand(*options, std::cout); }};
}

Subcommand addWaypointMetrics(CLI::App& app) {
  auto options = std::make_shared<waypoint::WaypointMetricsOptions>();
  auto config = std::make_shared<std::filesystem::path>();
  CLI::App* command = app.add_subcommand(
      "waypoint-metrics",
      "Candidate-waypoint predictor metrics (candidates, %Open, d_C, d_H) of "
      "the depth-only baseline against nav-graph targets on a split's houses");
  command->add_option("--dataset", options->dataset,
                      "Dataset root with <split>/ and connectivity/")
      ->capture_default_str();
  command->add_option("--scenes-dir", options->scenes_dir,
                      "Directory that the episodes' scene ids are relative to")
      ->capture_default_str();
  command->add_option("--split", options->split, "Split whose houses to score")
      ->capture_default_str();
  command->add_option("--max-nodes", options->max_nodes,
                      "Nodes per house, evenly spaced (-1: all)")
      ->capture_default_str();
  command->add_option("--seed", options->seed, "Seed of the agent's heading on "
                      "each node")->capture_default_str();
  command->add_option("--threads", options->threads,
                      "Houses scored in parallel")->capture_default_str();
  command->add_option("--config", *config,
                      "Run config YAML whose sim: section sets the navmesh, "
                      "agent and renderer, and panorama: section the views")
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out, "Write the JSON report here");
  command->add_flag("--json", options->json, "Print JSON instead of text");
  return {command, [options, config] {
            if (!config->empty()) {
              common::readConfigFileSection(
                  *config, "sim", {}, [&](common::ConfigVisitor& v) {
                    v.section("sim", options->sim, "Simulator");
                  });
              common::readConfigFileSection(
                  *config, "panorama", {}, [&](common::ConfigVisitor& v) {
                    v.section("panorama", options->panorama, "Panorama");
                  });
            }
            return waypoint::runWaypointMetricsCommand(*options, std::cout);
          }};
}

}  // namespace

int main(int argc, char** argv) {
  return common::runMain("vlnce-data", [&]() -> int {
    CLI::App app{"vlnce-data: tools for R2R_VLNCE-format datasets"};
    app.require_subcommand(1);
    std::string logLevel = "info";
    app.add_option("--log-level", logLevel,
                   "trace, debug, info, warn, error or off")
        ->capture_default_str();

    const std::vector<Subcommand> subcommands = {
        addStats(app),
        addGlove(app),
        addEmbeddings(app),
        addRxrMerge(app),
        addGenerate(app),
        addTransfer(app),
        addWaypointMetrics(app),
    };
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
    common::initLogging({}, logLevel);
    for (const Subcommand& subcommand : subcommands)
      if (subcommand.command->parsed()) return subcommand.run();
    return 1;
  });
}
