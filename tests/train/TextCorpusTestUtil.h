#pragma once
// A toy instruction corpus with structure for the text_mlm tests: an
// object's colour follows from the object and the room is named twice, so
// a contextual model can predict masked words a unigram model cannot. It is
// written as R2R-style splits (train, val_unseen) and as RxR-style splits
// (train, val_unseen; guide and follower files sharing instruction ids).

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "data/RxrEpisodes.h"

namespace vln::train::test {

/// Every toy sentence, in a fixed order (6 x 2 x 4 x 6 = 288).
inline std::vector<std::string> toySentences() {
  const std::array<std::pair<const char*, const char*>, 6> objects = {
      {{"chair", "red"},
       {"table", "blue"},
       {"sofa", "green"},
       {"lamp", "yellow"},
       {"bed", "white"},
       {"door", "black"}}};
  const std::array<const char*, 4> rooms = {"kitchen", "bedroom", "hallway",
                                            "bathroom"};
  std::vector<std::string> sentences;
  for (const auto& [object, color] : objects)
    for (const char* turn : {"left", "right"})
      for (const char* room : rooms)
        for (const auto& [object2, color2] : objects)
          sentences.push_back(std::string("Walk past the ") + color + " " +
                              object + " and turn " + turn + " into the " +
                              room + ". Stop near the " + color2 + " " +
                              object2 + " in the " + room + ".");
  return sentences;
}

/// An episode holding `text` (valid for writeEpisodes()).
inline data::Episode toyEpisode(int id, const std::string& text) {
  data::Episode e;
  e.episode_id = id;
  e.trajectory_id = id;
  e.scene_id = "mp3d/toy/toy.glb";
  e.instruction.instruction_text = text;
  return e;
}

/// The toy corpus under `root`: r2r/{train,val_unseen}/... (every 5th
/// sentence held out) and rxr/{train,val_unseen}/{split}_{guide,follower}
/// (instruction ids 1000 + i, en-US and hi-IN alternating; the follower
/// repeats the guide's first 10 instructions).
struct ToyCorpus {
  std::filesystem::path r2r;
  std::filesystem::path rxr;
  /// (split, id, language) of every RxR-style instruction, guide order.
  std::vector<std::tuple<std::string, int64_t, std::string>> rxr_instructions;
};

inline ToyCorpus writeToyCorpus(const std::filesystem::path& root) {
  ToyCorpus corpus{root / "r2r", root / "rxr", {}};
  const std::vector<std::string> sentences = toySentences();
  for (const std::string split : {"train", "val_unseen"}) {
    data::EpisodeDataset r2r;
    std::vector<data::Episode> guide;
    for (size_t i = 0; i < sentences.size(); ++i) {
      if ((i % 5 == 0) != (split == "val_unseen")) continue;
      const int id = static_cast<int>(i);
      r2r.episodes.push_back(toyEpisode(id, sentences[i]));
      data::Episode e = toyEpisode(id, sentences[i]);
      e.instruction.instruction_id = 1000 + id;
      e.instruction.language = i % 2 == 0 ? "en-US" : "hi-IN";
      guide.push_back(e);
      corpus.rxr_instructions.emplace_back(split, 1000 + id,
                                           e.instruction.language);
    }
    data::writeEpisodes(data::splitEpisodesPath(corpus.r2r, split), r2r);
    // the follower re-walks the guide's first instructions (same ids)
    std::vector<data::Episode> follower(guide.begin(), guide.begin() + 10);
    for (data::Episode& e : follower) e.episode_id += 100000;
    data::writeEpisodes(data::rxrEpisodesPath(corpus.rxr, split, "guide"),
                        {guide, std::nullopt});
    data::writeEpisodes(data::rxrEpisodesPath(corpus.rxr, split, "follower"),
                        {follower, std::nullopt});
  }
  return corpus;
}

}  // namespace vln::train::test
