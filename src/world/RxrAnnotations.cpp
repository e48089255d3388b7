#include "world/RxrAnnotations.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <utility>

#include "common/Check.h"

namespace vln::world {

namespace {

// A word of the text: its characters [begin, end) without punctuation.
struct WordSpan {
  size_t begin = 0;
  size_t end = 0;
};

bool isWordChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '\'' ||
         c == '-';
}

// White-space separated tokens with their leading and trailing punctuation
// stripped; tokens of punctuation only are dropped.
std::vector<WordSpan> splitWords(std::string_view text) {
  std::vector<WordSpan> words;
  size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() &&
           std::isspace(static_cast<unsigned char>(text[i])) != 0)
      ++i;
    size_t j = i;
    while (j < text.size() &&
           std::isspace(static_cast<unsigned char>(text[j])) == 0)
      ++j;
    size_t b = i, e = j;
    while (b < e && !isWordChar(text[b])) ++b;
    while (e > b && !isWordChar(text[e - 1])) --e;
    if (b < e) words.push_back({b, e});
    i = j;
  }
  return words;
}

// The time a mention's phrase is spoken (file comment of the header).
double anchorTime(const LandmarkMention& m, const WalkTimes& times) {
  const int last = static_cast<int>(times.arrival.size()) - 1;
  const int leg = std::clamp(m.leg, 0, last);
  switch (m.role) {
    case LandmarkRole::kTurnAt:
      return times.arrival[static_cast<size_t>(leg)];
    case LandmarkRole::kStop:
      return times.departure[static_cast<size_t>(std::max(last - 1, 0))];
    default:
      return times.departure[static_cast<size_t>(std::min(leg, last))];
  }
}

// en-US -> en-IN word choices (lower case, one word each).
const std::map<std::string, std::string>& indianWords() {
  static const std::map<std::string, std::string> kWords = {
      {"bathroom", "washroom"}, {"restroom", "washroom"},
      {"couch", "sofa"},        {"closet", "cupboard"},
      {"hallway", "passage"},   {"corridor", "passage"},
      {"walk", "move"},         {"go", "proceed"},

      {"rug", "carpet"},        {"fridge", "refrigerator"},
  };
  return kWords;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

WalkTimes walkTimes(const std::vector<Vec3f>& waypoints, double speed,
                    double pause) {
  VLN_CHECK_ARG(!waypoints.empty(), "walkTimes(): no waypoints");
  VLN_CHECK_ARG(speed > 0.0 && pause >= 0.0,
                "walkTimes(): speed must be > 0 and pause >= 0, got ", speed,
                " and ", pause);
  WalkTimes t;
  t.arrival.push_back(0.0);
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const bool goal = i + 1 == waypoints.size();
    t.departure.push_back(t.arrival[i] + (goal ? 0.0 : pause));
    if (!goal)
      t.arrival.push_back(
          t.departure[i] +
          static_cast<double>((waypoints[i + 1] - waypoints[i]).norm()) /
              speed);
  }
  return t;
}

std::vector<data::TimedWord> timeInstruction(
    const GeneratedInstruction& instruction, const WalkTimes& times) {
  const std::string& text = instruction.text;
  const std::vector<WordSpan> words = splitWords(text);
  const int n = static_cast<int>(words.size());
  if (n == 0) return {};
  const double duration = times.duration();

  // anchors: (word index, time); the first word at 0, the end of the last at
  // the end of the walk; each mention's first unused occurrence in the text
  std::map<int, double> anchors = {{0, 0.0}, {n, duration}};
  std::vector<bool> used(text.size(), false);
  for (const LandmarkMention& m : instruction.landmarks) {
    if (m.phrase.empty()) continue;
    size_t at = text.find(m.phrase);
    while (at != std::string::npos && used[at])
      at = text.find(m.phrase, at + 1);
    if (at == std::string::npos) continue;
    used[at] = true;
    const auto word =
        std::find_if(words.begin(), words.end(),
                     [&](const WordSpan& w) { return w.end > at; });
    const int index = static_cast<int>(word - words.begin());
    if (index <= 0 || index >= n) continue;
    anchors.emplace(index, std::clamp(anchorTime(m, times), 0.0, duration));
  }
  // times never go back: a later anchor is at least an earlier one
  double latest = 0.0;
  for (auto& [index, time] : anchors) {
    time = std::max(time, latest);
    latest = time;
  }

  // word starts interpolated between anchors; a word ends a little before
  // the next one starts
  std::vector<double> start(static_cast<size_t>(n) + 1);
  auto hi = anchors.begin();
  auto lo = hi;
  for (int k = 0; k <= n; ++k) {
    while (hi->first < k) lo = hi++;
    if (hi->first == k) {
      start[static_cast<size_t>(k)] = hi->second;
      continue;
    }
    const double f = static_cast<double>(k - lo->first) /
                     static_cast<double>(hi->first - lo->first);
    start[static_cast<size_t>(k)] = lo->second + f * (hi->second - lo->second);
  }
  std::vector<data::TimedWord> timed;
  timed.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const WordSpan& w = words[static_cast<size_t>(k)];
    const double s = start[static_cast<size_t>(k)];
    const double next = start[static_cast<size_t>(k) + 1];
    // milliseconds, as RxR's timestamps are; rounding keeps the order
    const auto ms = [](double t) { return std::round(t * 1000.0) / 1000.0; };
    timed.push_back({text.substr(w.begin, w.end - w.begin), ms(s),
                     ms(s + 0.85 * (next - s))});
  }
  return timed;
}

std::string toIndianEnglish(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 16);
  size_t i = 0;
  while (i < text.size()) {
    if (std::isalpha(static_cast<unsigned char>(text[i])) == 0) {
      out += text[i++];
      continue;
    }
    size_t j = i;
    while (j < text.size() &&
           std::isalpha(static_cast<unsigned char>(text[j])) != 0)
      ++j;
    const std::string_view word = text.substr(i, j - i);
    const bool followedByRoom = text.substr(j, 5) == " room";
    std::string replaced(word);
    const std::string key = lower(word);
    if (key == "living" && followedByRoom) {
      replaced = "drawing";
    } else if (const auto it = indianWords().find(key);
               it != indianWords().end() &&
               (j >= text.size() || text[j] != '\'')) {
      replaced = it->second;
    }
    if (std::isupper(static_cast<unsigned char>(word[0])) != 0)
      replaced[0] = static_cast<char>(
          std::toupper(static_cast<unsigned char>(replaced[0])));
    out += replaced;
    i = j;
  }
  return out;
}

}  // namespace vln::world
