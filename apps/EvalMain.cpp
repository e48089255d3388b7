// eval: evaluation of checkpoints, TorchScript exports and the no-learning
// baselines, and the paper's tables (see src/eval/EvalCommands.h).
#include <CLI/CLI.hpp>

#include "common/App.h"
#include "eval/EvalCommands.h"
#include "train/ExperimentConfig.h"

int main(int argc, char** argv) {
  // OpenMP threads that busy-wait long between LibTorch ops take the cores
  // from the environment threads rendering between policy steps (once 23
  // steps/s with libgomp's default against 672 with PASSIVE); the short
  // spin every binary uses is faster still: all 270 val_unseen episodes of
  // the main job in 7.3-7.7 s against 9.2-9.3 s with PASSIVE
  // (docs/performance.md, "OpenMP wait policy").
  vln::common::pinNumericalRuntime("eval", argv);
  return vln::common::runMain("eval", [&] {
    CLI::App app{
        "Evaluate VLN-CE checkpoints, exports and baselines; build the paper's "
        "tables"};
    std::filesystem::path config;
    std::vector<std::string> overrides;
    std::string logLevel = "info";
    vln::eval::EvalCommandOptions options;
    int episodes = 0, maps = 0, videos = 0, index = 0;
    app.add_option("--config", config, "Run config YAML");
    app.add_option("--set", overrides,
                   "Override: section.key=value (repeatable)");
    app.add_option(
        "--checkpoint", options.checkpoint,
        "ckpt.<i>.pth, a directory of them, or a TorchScript .pt export");
    app.add_option("--ensemble", options.ensemble,
                   "With a waypoint agent's --checkpoint file: more "
                   "checkpoints or run directories (their best) of the same "
                   "recipe whose choice probabilities are averaged with it "
                   "(repeatable)");
    app.add_option("--agent", options.agent,
                   "Evaluate a baseline instead: random, handcrafted or oracle "
                   "(trainer.expert's shortest-path expert)");
    app.add_option("--split", options.splits,
                   "Split to evaluate (repeatable; default eval.splits)");
    auto* episodesOption = app.add_option(
        "--episodes", episodes, "Episodes per split (default eval.episodes)");
    app.add_option("--out", options.out,
                   "Output directory (default <output.dir>/eval)");
    app.add_option("--navgraph", options.navgraph,
                   "Directory of <scan>_connectivity.json: also score on the "
                   "nav-graph (Table 3)");
    auto* mapsOption = app.add_option(
        "--maps", maps, "Top-down maps per split (default eval.map_episodes)");
    auto* videosOption = app.add_option(
        "--videos", videos, "Videos per split (default eval.video_episodes)");
    app.add_option("--video-format", options.video_format,
                   "Video container: avi (MJPG) or mp4 (mp4v)");
    app.add_option("--report", options.report,
                   "Write an HTML report (one page per checkpoint and split, "
                   "and an index) "
                   "into this folder");
    app.add_option("--report-episodes", options.report_episodes,
                   "Episodes per report page with a map, frames and attention "
                   "(default 5)");
    app.add_option("--test-ground-truth", options.test_ground_truth,
                   "Score the test split (RxR: test_challenge) from its "
                   "hidden goals and ground truth (<data>/hidden, written by "
                   "vlnce-data generate; either file or a folder holding "
                   "them); its leaderboard predictions are still written");
    auto* indexOption = app.add_option(
        "--index", index,
        "Checkpoint index in file names for an export or a baseline");
    app.add_option("--log-level", logLevel,
                   "trace, debug, info, warn or error");
    // observation dumps (src/eval/DumpOptions.h, docs/dumps.md)
    int dumpEpisodes = 0;
    app.add_option("--dump", options.dump.dir,
                   "Write per-step RGB, depth (mm), pose and action of the "
                   "episodes to DIR/<split>/<episode_id>/ (docs/dumps.md)");
    auto* dumpEpisodesOption =
        app.add_option("--dump-episodes", dumpEpisodes,
                       "Dump the first N episodes of each split (default: all)");
    app.add_option("--dump-ids", options.dump.ids,
                   "Dump these episode ids (comma-separated)");
    app.add_option("--dump-format", options.dump.format,
                   "RGB images of the dump: png or jpg");

    // the subcommands that read result folders: both take --runs and --out
    auto resultsCommand = [&](const char* name, const char* help,
                              std::filesystem::path& runs,
                              std::filesystem::path& out, const char* outHelp) {
      CLI::App* command = app.add_subcommand(name, help);
      command
          ->add_option("--runs", runs,
                       "Results directory (run folders at any depth, each with "
                       "run.json)")
          ->required();
      command->add_option("--out", out, outHelp)->required();
      return command;
    };
    vln::eval::TablesCommandOptions tables;
    CLI::App* tablesCommand = resultsCommand(
        "tables",
        "Rebuild the paper's Tables 1-3 from result files, ours beside the "
        "paper's; several runs "
        "of one row (one per seed) print mean ± 95% Student t half-width and "
        "their count n",
        tables.runs, tables.out, "Markdown file (LaTeX written beside it)");
    tablesCommand->add_flag(
        "--claimed-only", tables.claimed_only,
        "Only the rows some run claims (and tables that have one)");
    vln::eval::CompareCommandOptions compare;
    CLI::App* compareCommand = resultsCommand(
        "compare",
        "Judge the paper's findings (row A beats row B) by paired differences "
        "over seeds on "
        "val_unseen SR and SPL: holds, does not hold or cannot tell",
        compare.runs, compare.out, "Markdown file");
    vln::eval::CurveCommandOptions curve;
    CLI::App* curveCommand = app.add_subcommand(
        "curve",
        "Draw a training run's learning curve as a PNG: SR and SPL of its "
        "periodic validations (metrics.jsonl) against wall time and updates");
    curveCommand
        ->add_option("--run", curve.run,
                     "Training run directory (output.dir, with metrics.jsonl)")
        ->required();
    curveCommand->add_option("--out", curve.out, "PNG file")->required();
    curveCommand->add_option("--split", curve.split,
                             "Validated split to draw (default val_unseen)");
    curveCommand->add_option("--title", curve.title,
                             "Title (default: the split and the run folder)");
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& error) {
      return app.exit(error);
    }
    vln::common::initLogging({}, logLevel);
    if (tablesCommand->parsed())
      return vln::eval::runTablesCommand(tables, std::cout);
    if (compareCommand->parsed())
      return vln::eval::runCompareCommand(compare, std::cout);
    if (curveCommand->parsed())
      return vln::eval::runCurveCommand(curve, std::cout);

    if (config.empty())
      throw std::invalid_argument("eval: --config is required");
    if (*episodesOption) options.episodes = episodes;
    if (*mapsOption) options.maps = maps;
    if (*videosOption) options.videos = videos;
    if (*indexOption) options.index = index;
    if (*dumpEpisodesOption) options.dump.episodes = dumpEpisodes;
    const auto experiment = vln::train::loadExperimentConfig(config, overrides);
    return vln::eval::runEvalCommand(options, experiment, std::cout);
  });
}
