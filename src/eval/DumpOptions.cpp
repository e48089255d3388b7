#include "eval/DumpOptions.h"

#include <charconv>
#include <set>

#include "common/Check.h"

namespace vln::eval {

std::vector<int> parseEpisodeIds(std::string_view text, std::string_view flag) {
  std::vector<int> ids;
  std::set<int> seen;
  size_t start = 0;
  while (true) {
    // one entry, trimmed of spaces
    const size_t comma = text.find(',', start);
    std::string_view entry = text.substr(start, comma == std::string_view::npos
                                                    ? std::string_view::npos
                                                    : comma - start);
    while (!entry.empty() && entry.front() == ' ') entry.remove_prefix(1);
    while (!entry.empty() && entry.back() == ' ') entry.remove_suffix(1);
    VLN_CHECK_ARG(!entry.empty(), flag,
                  ": expected comma-separated episode ids, got '", text,
                  "' (an empty entry)");
    int id = 0;
    const auto [end, error] =
        std::from_chars(entry.data(), entry.data() + entry.size(), id);
    VLN_CHECK_ARG(
        error == std::errc() && end == entry.data() + entry.size() && id >= 0,
        flag, ": '", entry, "' is not an episode id (an integer >= 0), in '",
        text, "'");
    VLN_CHECK_ARG(seen.insert(id).second, flag, ": episode id ", id,
                  " is listed twice, in '", text, "'");
    ids.push_back(id);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return ids;
}

void checkDumpOptions(const DumpOptions& options,
                      std::span<const data::Split> splits, size_t candidates,
                      const train::ExperimentConfig& config) {
  // flags that need --dump
  if (options.dir.empty()) {
    VLN_CHECK_ARG(!options.episodes, "eval: --dump-episodes needs --dump DIR");
    VLN_CHECK_ARG(options.ids.empty(), "eval: --dump-ids needs --dump DIR");
    VLN_CHECK_ARG(options.format == "png",
                  "eval: --dump-format needs --dump DIR");
    return;
  }
  VLN_CHECK_ARG(!options.episodes || *options.episodes >= 1,
                "eval: --dump-episodes must be >= 1, got ", *options.episodes);
  VLN_CHECK_ARG(!options.episodes || options.ids.empty(),
                "eval: give --dump-episodes or --dump-ids, not both");
  VLN_CHECK_ARG(options.format == "png" || options.format == "jpg",
                "eval: --dump-format must be png or jpg, got '", options.format,
                "'");
  VLN_CHECK_ARG(candidates <= 1,
                "eval: --dump takes one checkpoint, export or agent, not a "
                "directory of ",
                candidates, " checkpoints (their dumps would share '",
                options.dir.string(), "')");

  // no episode folder to write exists (the observers check again, split
  // by split, but this fails before any episode runs)
  for (const data::Split& split : splits)
    (void)makeObservationDump(options, split, config, "");

  // every listed id is evaluated somewhere
  if (options.ids.empty()) return;
  std::string names;
  for (const data::Split& split : splits)
    names += (names.empty() ? "" : ", ") + split.name;
  for (int id : parseEpisodeIds(options.ids, "eval: --dump-ids")) {
    bool found = false;
    for (const data::Split& split : splits)
      for (const data::Episode& episode : split.episodes)
        found = found || episode.episode_id == id;
    VLN_CHECK_ARG(found, "eval: --dump-ids: episode ", id,
                  " is in none of the evaluated splits (", names,
                  "; --episodes keeps a subset)");
  }
}

std::unique_ptr<viz::ObservationDump> makeObservationDump(
    const DumpOptions& options, const data::Split& split,
    const train::ExperimentConfig& config, const std::string& agent) {
  if (options.dir.empty()) return nullptr;
  viz::DumpConfig dump;
  dump.dir = options.dir;
  dump.split = split.name;
  dump.first_episodes = options.episodes.value_or(-1);
  if (!options.ids.empty())
    dump.episode_ids = parseEpisodeIds(options.ids, "eval: --dump-ids");
  dump.format = options.format;
  dump.rgb = config.sim.rgb;
  dump.depth = config.sim.depth;
  dump.agent = agent;
  dump.vocabulary = split.vocabulary ? &*split.vocabulary : nullptr;
  return std::make_unique<viz::ObservationDump>(std::move(dump),
                                                split.episodes);
}

}  // namespace vln::eval
