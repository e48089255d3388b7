#include "world/InstructionGenerator.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <map>
#include <random>
#include <utility>

#include "common/Check.h"
#include "common/Random.h"
#include "world/PathFacts.h"

namespace vln::world {

using namespace instruction;

namespace {

// ===========================================================================
// words
// ===========================================================================

std::vector<std::string> colorWords(const std::string& color) {
  if (color == "wooden") return {"wooden", "wood"};
  if (color == "grey" || color == "gray") return {"grey", "gray"};
  return {color};
}

const char* pick(std::mt19937_64& rng,
                 std::initializer_list<const char*> options) {
  VLN_ASSERT(options.size() > 0);
  return options.begin()[common::uniformIndex(rng, static_cast<int>(options.size()))];
}

const std::string& pick(std::mt19937_64& rng,
                        const std::vector<std::string>& options) {
  VLN_ASSERT(!options.empty());
  return options[static_cast<size_t>(
      common::uniformIndex(rng, static_cast<int>(options.size())))];
}

// `form` with its '#' replaced by `side` ("take a #" -> "take a left")
std::string withSide(std::string form, const char* side) {
  form.replace(form.find('#'), 1, side);
  return form;
}

const char* sideWord(Side side) {
  return side == Side::kLeft ? "left" : "right";
}

Side flip(Side side) {
  return side == Side::kLeft    ? Side::kRight
         : side == Side::kRight ? Side::kLeft
                                : Side::kNone;
}

// ===========================================================================
// writing one instruction
// ===========================================================================

// A clause with its position along the path (for ordering).
struct Clause {
  float s = 0.0f;
  std::string text;
};

class Writer {
 public:
  Writer(const sim::SceneSemantics& semantics, const InstructionConfig& config,
         const PathFacts& facts, const std::vector<Nameability>& names,
         InstructionStyle style, uint64_t seed)
      : semantics_(semantics),
        config_(config),
        facts_(facts),
        names_(names),
        human_(style == InstructionStyle::kHuman),
        rng_(seed) {}

  GeneratedInstruction write() {
    std::vector<Clause> clauses;
    std::vector<bool> transitionUsed(facts_.transitions.size(), false);
    opening(clauses, transitionUsed);
    middle(clauses, transitionUsed);
    clauses.push_back({facts_.total, stopClause()});
    GeneratedInstruction out;
    out.text = human_ ? assembleHuman(clauses, out.sub_instructions)
                      : assembleSpeaker(clauses, out.sub_instructions);
    out.landmarks = std::move(mentions_);
    out.goal_room = facts_.stop.room;
    return out;
  }

 private:
  bool chance(double p) { return common::bernoulli(rng_, p); }

  // --- names -------------------------------------------------------------

  std::string roomName(int room) {
    if (room < 0) return "room";
    const auto& words =
        roomTypeWords(semantics_.rooms[static_cast<size_t>(room)].type);
    return human_ ? pick(rng_, words) : words.front();
  }

  // "white fridge" / "fridge"; records a mention. A speaker may get the
  // colour wrong (it then always states a colour, since that is the error).
  std::string objectPhrase(int index, LandmarkRole role, Side side, int leg,
                           bool truthfulSide = true) {
    const auto& object = semantics_.objects[static_cast<size_t>(index)];
    const auto& categories = objectCategoryWords(object.category);
    const std::string category =
        human_ ? pick(rng_, categories) : categories.front();
    bool truthful = truthfulSide;
    std::string color;
    const bool wantColor =
        names_[static_cast<size_t>(index)].needs_color ||
        chance(human_ ? config_.detail : 0.3 * config_.detail);
    if (!human_ && !object.color.empty() &&
        chance(config_.speaker_wrong_color)) {
      color = wrongColor(object.color);
      truthful = color.empty() ? truthful : false;
    }
    if (color.empty() && wantColor && !object.color.empty())
      color = pick(rng_, colorWords(object.color));
    const std::string phrase =
        color.empty() ? category : color + " " + category;
    mentions_.push_back({object.id, role, phrase, side, leg, truthful});
    return phrase;
  }

  // A colour of another object in the house, never the true one.
  std::string wrongColor(const std::string& truth) {
    std::vector<std::string> others;
    for (const auto& o : semantics_.objects)
      if (!o.color.empty() && o.color != truth &&
          std::find(others.begin(), others.end(), o.color) == others.end())
        others.push_back(o.color);
    return others.empty() ? std::string() : pick(rng_, others);
  }

  // --- clauses -----------------------------------------------------------

  // A turn to the left or right: the template style's `form`, or one of the
  // human `forms` (equally likely), with '#' replaced by the side.
  std::string sidedTurn(bool left, const char* form,
                        std::initializer_list<const char*> forms) {
    return withSide(human_ ? pick(rng_, forms) : form, left ? "left" : "right");
  }

  std::string turnPhrase(TurnKind kind) {
    switch (kind) {
      // the plain "turn #" is the most common human form
      case TurnKind::kLeft:
      case TurnKind::kRight:
        return sidedTurn(kind == TurnKind::kLeft, "turn #",
                         {"take a #", "make a #", "turn to your #", "go #",
                          "take a # turn", "turn #", "turn #"});
      case TurnKind::kSlightLeft:
      case TurnKind::kSlightRight:
        return sidedTurn(kind == TurnKind::kSlightLeft, "turn slightly #",
                         {"veer #", "bear #", "take a slight #",
                          "turn slightly to the #", "turn slightly #"});
      case TurnKind::kSharpLeft:
      case TurnKind::kSharpRight:
        return sidedTurn(kind == TurnKind::kSharpLeft, "turn #",
                         {"make a sharp #", "turn sharply #", "take a sharp #",
                          "turn sharp #"});
      case TurnKind::kAround:
        if (!human_) return "turn around";
        return pick(rng_, {"turn around", "turn around", "turn around",
                           "turn all the way around"});
      case TurnKind::kStraight:
        break;
    }
    return human_ ? pick(rng_,
                         {"walk forward", "go straight", "walk straight ahead",
                          "head straight", "move forward"})
                  : "walk forward";
  }

  std::string walkVerb() {
    return human_ ? pick(rng_,
                         {"walk", "go", "head", "walk", "continue", "proceed"})
                  : "walk";
  }

  std::string transitionPhrase(const Transition& t, bool first) {
    const std::string to = roomName(t.to);
    const bool hallway =
        t.to >= 0 &&
        semantics_.rooms[static_cast<size_t>(t.to)].type == "hallway";
    if (!human_) {
      if (first && chance(0.5))
        return strCat("walk out of the ", roomName(t.from));
      return strCat("walk into the ", to);
    }
    if (first && chance(0.55)) {
      const std::string from = roomName(t.from);
      std::string out =
          pick(rng_, {"exit the ", "leave the ", "walk out of the ",
                      "go out of the ", "exit the "}) +
          from;
      if (chance(0.4))
        out += t.door ? strCat(" through the ", pick(rng_, {"doorway", "door"}))
                      : strCat(" into the ", to);
      return out;
    }
    if (t.door && chance(0.45))
      return strCat(pick(rng_, {"go through the ", "walk through the ",
                                "pass through the ", "head through the "}),
                    pick(rng_, {"doorway", "door", "doorway"}), " ",
                    pick(rng_, {"into", "to", "into"}), " the ", to);
    std::string out =
        strCat(pick(rng_, {"enter the ", "walk into the ", "go into the ",
                           "head into the ", "step into the ", "enter the "}),
               to);
    if (hallway && chance(0.25))
      out += strCat(
          " and ",
          pick(rng_, {"walk down", "go down", "continue down", "walk along"}),
          " the ", roomName(t.to));
    return out;
  }

  std::string passPhrase(const Pass& pass) {
    Side side = pass.side;
    bool truthful = true;
    if (!human_ && chance(config_.speaker_wrong_side)) {
      side = flip(side);
      truthful = false;
    }
    const bool sayside = !human_ || chance(0.7);
    const Side stated = sayside ? side : Side::kNone;
    if (human_ && sayside && chance(0.2)) {
      const std::string what = objectPhrase(pass.object, LandmarkRole::kPass,
                                            stated, pass.leg, truthful);
      return strCat(pick(rng_, {"keep the ", "keep the "}), what, " on your ",
                    sideWord(side));
    }
    const std::string verb =
        human_ ? pick(rng_, {"walk past the ", "pass the ", "go past the ",
                             "walk by the ", "continue past the ",
                             "walk passed the ", "head past the "})
               : "walk past the ";
    const std::string what = objectPhrase(pass.object, LandmarkRole::kPass,
                                          stated, pass.leg, truthful);
    if (!sayside) return verb + what;
    return strCat(
        verb, what,
        human_ ? pick(rng_, {" on your ", " on the ", " to your ", " on your "})
               : " on your ",
        sideWord(side));
  }

  std::string betweenPhrase(const Pass& a, const Pass& b) {
    const std::string first =
        objectPhrase(a.object, LandmarkRole::kBetween, Side::kNone, a.leg);
    const std::string second =
        objectPhrase(b.object, LandmarkRole::kBetween, Side::kNone, b.leg);
    return strCat(pick(rng_, {"walk between the ", "go between the ",
                              "pass between the "}),
                  first, " and the ", second);
  }

  std::string towardPhrase(const Toward& t) {
    return strCat(
        pick(rng_, {"walk towards the ", "head towards the ", "go toward the ",
                    "walk toward the ", "move towards the "}),
        objectPhrase(t.object, LandmarkRole::kToward, Side::kNone, t.leg));
  }

  // The object nearest to waypoint `w` to "turn at", or -1.
  // True for objects already named or kept for the stop clause: each
  // landmark is named once.
  bool reserved(int object) const {
    if (object == facts_.stop.object) return true;
    const int id = semantics_.objects[static_cast<size_t>(object)].id;
    return std::any_of(
        mentions_.begin(), mentions_.end(),
        [&](const LandmarkMention& m) { return m.object_id == id; });
  }

  int turnAnchor(int w) const {
    const Vec3f& p = facts_.waypoints[static_cast<size_t>(w)];
    const int room = semantics_.roomAt(p);
    int best = -1;
    float bestDistance = kTurnAnchorDistance;
    for (size_t o = 0; o < semantics_.objects.size(); ++o) {
      const auto& object = semantics_.objects[o];
      if (!names_[o].nameable || object.room != room || room < 0 ||
          reserved(static_cast<int>(o)))
        continue;
      const float d = footprintDistance(object.bounds, p);
      if (d <= bestDistance) {
        bestDistance = d;
        best = static_cast<int>(o);
      }
    }
    return best;
  }

  void opening(std::vector<Clause>& clauses,
               std::vector<bool>& transitionUsed) {
    // the first move relative to where the agent faces; walking straight
    // off is often left unsaid
    const TurnKind kind = facts_.initial;
    std::string text;
    if (kind != TurnKind::kStraight || chance(human_ ? 0.2 : 0.3))
      text = turnPhrase(kind);
    // joined with leaving the start room when that comes first
    if (!facts_.transitions.empty() && facts_.transitions.front().s < 3.0f &&
        !text.empty() && chance(0.5)) {
      text += " and " +
              transitionPhrase(facts_.transitions.front(), /*first=*/true);
      transitionUsed[0] = true;
    }
    if (!text.empty()) clauses.push_back({0.0f, text});
  }

  void middle(std::vector<Clause>& clauses, std::vector<bool>& transitionUsed) {
    // choose the landmarks this instruction mentions
    const double passChance = human_ ? 0.1 + 0.3 * config_.detail
                                     : 1.0 - config_.speaker_drop_landmark;
    const size_t maxPasses = human_ ? 2 : 1;
    std::vector<int> chosen;
    for (size_t i = 0; i < facts_.passes.size(); ++i)
      if (chosen.size() < maxPasses &&
          facts_.passes[i].object != facts_.stop.object && chance(passChance))
        chosen.push_back(static_cast<int>(i));

    // passes (pairs on opposite sides close together become "between")
    std::vector<bool> legHasLandmark(facts_.heading.size(), false);
    for (size_t k = 0; k < chosen.size(); ++k) {
      const Pass& a = facts_.passes[static_cast<size_t>(chosen[k])];
      legHasLandmark[static_cast<size_t>(a.leg)] = true;
      if (human_ && k + 1 < chosen.size()) {
        const Pass& b = facts_.passes[static_cast<size_t>(chosen[k + 1])];
        if (b.side != a.side && b.s - a.s < 1.0f && chance(0.7)) {
          clauses.push_back({a.s, betweenPhrase(a, b)});
          ++k;
          continue;
        }
      }
      clauses.push_back({a.s, passPhrase(a)});
    }

    // "walk towards" a landmark ahead on a leg without another landmark
    if (human_) {
      for (const Toward& t : facts_.towards) {
        // the stop landmark is named once, at the stop
        if (legHasLandmark[static_cast<size_t>(t.leg)] || reserved(t.object) ||
            !chance(0.2 * config_.detail + 0.1))
          continue;
        legHasLandmark[static_cast<size_t>(t.leg)] = true;
        clauses.push_back({t.s + 0.01f, towardPhrase(t)});
      }
    }

    // turns, sometimes anchored at a landmark or merged with the next room
    for (const Turn& turn : facts_.turns) {
      // annotators often leave slight bends unsaid
      const bool slight = turn.kind == TurnKind::kSlightLeft ||
                          turn.kind == TurnKind::kSlightRight;
      if (slight && chance(human_ ? 0.55 : 0.4)) continue;
      std::string text = turnPhrase(turn.kind);
      const int anchor = human_ ? turnAnchor(turn.waypoint) : -1;
      if (anchor >= 0 && chance(0.3 * config_.detail + 0.05))
        text += strCat(" at the ", objectPhrase(anchor, LandmarkRole::kTurnAt,
                                                Side::kNone, turn.waypoint));
      for (size_t t = 0; t < facts_.transitions.size(); ++t) {
        const Transition& tr = facts_.transitions[t];
        if (transitionUsed[t] || tr.s < turn.s || tr.s > turn.s + 1.5f)
          continue;
        if (human_ && chance(0.6)) {
          text += strCat(" into the ", roomName(tr.to));
          transitionUsed[t] = true;
        }
        break;
      }
      clauses.push_back({turn.s, text});
    }

    // room changes not already said; rooms merely walked through are
    // sometimes skipped, the goal's room rarely
    for (size_t t = 0; t < facts_.transitions.size(); ++t) {
      if (transitionUsed[t]) continue;
      const bool intoGoalRoom = t + 1 == facts_.transitions.size();
      if (!chance(intoGoalRoom ? 0.9 : (human_ ? 0.5 : 0.55))) continue;
      clauses.push_back({facts_.transitions[t].s - 0.01f,
                         transitionPhrase(facts_.transitions[t], t == 0)});
    }

    // "continue straight" on long legs that nothing else describes
    if (human_) {
      for (size_t leg = 0; leg + 1 < facts_.leg_start.size(); ++leg) {
        const float begin = facts_.leg_start[leg];
        const float end = facts_.leg_start[leg + 1];
        if (end - begin < 3.0f || legHasLandmark[leg] || !chance(0.2)) continue;
        bool described = false;
        for (const Clause& c : clauses)
          if (c.s >= begin && c.s < end) described = true;
        if (!described)
          clauses.push_back(
              {begin + 0.02f,
               pick(rng_, {"continue straight", "walk straight",
                           "keep going straight", "go straight ahead",
                           "continue forward"})});
      }
    }
    std::stable_sort(
        clauses.begin(), clauses.end(),
        [](const Clause& a, const Clause& b) { return a.s < b.s; });
  }

  std::string stopClause() {
    const StopPlan& stop = facts_.stop;
    const int leg = static_cast<int>(facts_.waypoints.size()) - 1;
    if (!human_) {
      if (stop.object >= 0 && chance(0.8)) {
        const char* rel =
            stop.ahead ? "stop in front of the " : "wait near the ";
        return rel +
               objectPhrase(stop.object, LandmarkRole::kStop, Side::kNone, leg);
      }
      if (stop.door) return "stop in the doorway";
      return strCat("stop in the ", roomName(stop.room));
    }

    const std::string verb =
        pick(rng_, {"stop", "stop", "wait", "stop", "wait"});
    if (stop.object >= 0 && chance(0.85)) {
      const Side side =
          stop.side != Side::kNone && chance(0.3) ? stop.side : Side::kNone;
      const std::string what =
          objectPhrase(stop.object, LandmarkRole::kStop, side, leg);
      std::string out;
      switch (common::uniformIndex(rng_, 4)) {
        case 0:
          out = strCat(verb, " once you reach the ", what);
          break;
        case 1:
          out = strCat(verb, " when you get to the ", what);
          break;
        default: {
          const std::string rel =
              stop.ahead
                  ? pick(rng_, {"in front of", "next to", "near", "by",
                                "in front of"})
                  : pick(rng_, {"next to", "beside", "near", "by", "next to"});
          out = strCat(pick(rng_, {"stop", "wait", "stand", "stop"}), " ", rel,
                       " the ", what);
        }
      }
      if (side != Side::kNone)
        out += strCat(" on your ", sideWord(side));
      else if (chance(0.4 * config_.detail))
        out += strCat(" in the ", roomName(stop.room));
      return out;
    }
    if (stop.door)
      return chance(0.5)
                 ? strCat(verb, " in the doorway")
                 : strCat(verb, " in the doorway of the ", roomName(stop.room));
    if (stop.just_entered)
      return pick(rng_,
                  {"stop once you enter the ", "stop just inside the ",
                   "wait just inside the ", "stop as soon as you enter the "}) +
             roomName(stop.room);
    if (stop.near_center)
      return strCat(verb, " in the ",
                    pick(rng_, {"middle", "center", "middle"}), " of the ",
                    roomName(stop.room));
    return strCat(verb, " ", pick(rng_, {"in", "inside"}), " the ",
                  roomName(stop.room));
  }

  // --- sentences ---------------------------------------------------------

  // The leg a clause at distance `s` along the path describes: the last
  // waypoint at or before it (the last waypoint itself only at the path's
  // end, where the stop clause is).
  int legAt(float s) const {
    const auto& starts = facts_.leg_start;
    const auto it = std::upper_bound(starts.begin(), starts.end(), s);
    return std::clamp(static_cast<int>(it - starts.begin()) - 1, 0,
                      static_cast<int>(starts.size()) - 1);
  }

  // clause `clause` placed at byte `at` of the text
  data::SubInstruction subInstruction(const Clause& clause, size_t at) const {
    return {static_cast<int>(at), static_cast<int>(at + clause.text.size()),
            legAt(clause.s)};
  }

  // The text, and in `spans` where each clause went (the random draws are
  // those of the text alone, so recording them changes no instruction).
  std::string assembleHuman(const std::vector<Clause>& clauses,
                            std::vector<data::SubInstruction>& spans) {
    // one to three clauses per sentence, joined by varied connectives
    std::vector<std::string> sentences;
    // per sentence, its clauses' spans relative to the sentence
    std::vector<std::vector<data::SubInstruction>> sentenceSpans;
    std::vector<data::SubInstruction> currentSpans;
    std::string current;
    int inSentence = 0;
    int target = 1 + common::uniformIndex(rng_, 3);
    for (size_t i = 0; i < clauses.size(); ++i) {
      if (inSentence == 0) {
        current = clauses[i].text;
        if (!sentences.empty() && chance(0.25))
          current = pick(rng_, {"then ", "next, ", "after that, ", "now ",
                                "from there, "}) +
                    current;
        currentSpans = {subInstruction(
            clauses[i], current.size() - clauses[i].text.size())};
      } else {
        current += pick(
            rng_, {" and ", ", then ", ", ", " and then ", ", and ", " and "});
        currentSpans.push_back(subInstruction(clauses[i], current.size()));
        current += clauses[i].text;
      }
      ++inSentence;
      if (inSentence >= target || i + 1 == clauses.size()) {
        sentences.push_back(current);
        sentenceSpans.push_back(std::move(currentSpans));
        currentSpans.clear();
        inSentence = 0;
        target = 1 + common::uniformIndex(rng_, 3);
      }
    }
    std::string text;
    for (size_t k = 0; k < sentences.size(); ++k) {
      std::string& s = sentences[k];
      s[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
      if (!text.empty()) text += chance(0.1) ? ".  " : ". ";
      for (data::SubInstruction span : sentenceSpans[k]) {
        span.begin += static_cast<int>(text.size());
        span.end += static_cast<int>(text.size());
        spans.push_back(span);
      }
      text += s;
    }
    text += chance(0.85) ? "." : ". ";
    return text;
  }

  std::string assembleSpeaker(const std::vector<Clause>& clauses,
                              std::vector<data::SubInstruction>& spans) {
    std::string text;
    for (size_t i = 0; i < clauses.size(); ++i) {
      if (i > 0) text += (i % 2 == 1) ? " and " : " . ";
      spans.push_back(subInstruction(clauses[i], text.size()));
      text += clauses[i].text;
    }
    return text + " .";
  }

  const sim::SceneSemantics& semantics_;
  const InstructionConfig& config_;
  const PathFacts& facts_;
  const std::vector<Nameability>& names_;
  bool human_;
  std::mt19937_64 rng_;
  std::vector<LandmarkMention> mentions_;
};

}  // namespace

// ===========================================================================
// public API
// ===========================================================================

std::vector<std::string> roomTypeWords(const std::string& type) {
  static const std::map<std::string, std::vector<std::string>> kWords = {
      {"hallway", {"hallway", "hall", "corridor", "hallway"}},
      {"living room", {"living room", "lounge", "family room", "living room"}},
      {"bathroom", {"bathroom", "restroom", "washroom", "bathroom"}},
      {"dining room", {"dining room", "dining area", "dining room"}},
      {"office", {"office", "study", "office"}},
      {"laundry room", {"laundry room", "laundry"}},
      {"closet", {"closet"}},
      {"kitchen", {"kitchen"}},
      {"bedroom", {"bedroom"}},
  };
  auto it = kWords.find(type);
  return it == kWords.end() ? std::vector<std::string>{type} : it->second;
}

std::vector<std::string> objectCategoryWords(const std::string& category) {
  static const std::map<std::string, std::vector<std::string>> kWords = {
      {"sofa", {"sofa", "couch", "sofa"}},
      {"couch", {"couch", "sofa"}},
      {"tv", {"tv", "television", "tv"}},
      {"television", {"television", "tv"}},
      {"fridge", {"fridge", "refrigerator", "fridge"}},
      {"refrigerator", {"refrigerator", "fridge"}},
      {"plant", {"plant", "potted plant", "plant"}},
      {"bookshelf", {"bookshelf", "bookcase", "bookshelf"}},
      {"bookcase", {"bookcase", "bookshelf"}},
      {"armchair", {"armchair", "chair", "armchair"}},
      {"bathtub", {"bathtub", "tub", "bathtub"}},
      {"counter", {"counter", "kitchen counter", "counter"}},
      {"stove", {"stove", "oven"}},
      {"oven", {"oven", "stove"}},
      {"washing machine", {"washing machine", "washer"}},
      {"washer", {"washer", "washing machine"}},
      {"dining table", {"dining table", "table"}},
      {"coffee table", {"coffee table", "table"}},
      {"nightstand", {"nightstand", "night stand"}},
      {"painting", {"painting", "picture", "painting"}},
      {"picture", {"picture", "painting"}},
      {"shelf", {"shelf", "shelves"}},
      {"wardrobe", {"wardrobe", "armoire"}},
      {"lamp", {"lamp", "floor lamp", "lamp"}},
  };
  auto it = kWords.find(category);
  return it == kWords.end() ? std::vector<std::string>{category} : it->second;
}

float footprintDistance(const Eigen::AlignedBox3f& box, const Vec3f& p) {
  const float dx =
      std::max({box.min().x() - p.x(), 0.0f, p.x() - box.max().x()});
  const float dz =
      std::max({box.min().z() - p.z(), 0.0f, p.z() - box.max().z()});
  return std::hypot(dx, dz);
}

InstructionGenerator::InstructionGenerator(const sim::SceneSemantics& semantics,
                                           const InstructionConfig& config)
    : semantics_(semantics), config_(config) {}

std::vector<GeneratedInstruction> InstructionGenerator::generate(
    const std::vector<Vec3f>& waypoints, float startHeading,
    InstructionStyle style, int count, uint64_t seed) const {
  VLN_CHECK_ARG(waypoints.size() >= 2,
                "InstructionGenerator::generate(): a path needs at least two "
                "waypoints, got ",
                waypoints.size());
  for (size_t i = 0; i < waypoints.size(); ++i)
    VLN_CHECK_ARG(waypoints[i].allFinite(),
                  "InstructionGenerator::generate(): waypoint ", i,
                  " is not finite, got [", waypoints[i].transpose(), "]");
  const std::vector<Nameability> names = nameability(semantics_);
  const PathFacts facts =
      analyzePath(semantics_, waypoints, startHeading, config_, names);

  // human instructions of one path differ, as three annotators' do; a
  // repeated draw is redrawn a bounded number of times (a path with nothing
  // to describe can only be said a few ways)
  constexpr int kRedraws = 12;
  std::vector<GeneratedInstruction> result;
  uint64_t draw = 0;
  for (int i = 0; i < count; ++i) {
    GeneratedInstruction instruction;
    for (int attempt = 0; attempt <= kRedraws; ++attempt) {
      Writer writer(semantics_, config_, facts, names, style,
                    common::deriveSeed(seed, draw++));
      instruction = writer.write();
      const bool repeated = std::any_of(result.begin(), result.end(),
                                        [&](const GeneratedInstruction& r) {
                                          return r.text == instruction.text;
                                        });
      if (style == InstructionStyle::kSpeaker || !repeated) break;
    }
    result.push_back(std::move(instruction));
  }
  return result;
}

}  // namespace vln::world
