#pragma once
// English navigation instructions for a path through a house, in the manner
// of Room-to-Room's annotators: rooms left and entered, turns at the
// waypoints, landmarks passed (with colour and side), and where to stop.
// Every statement is grounded in the house's semantics: a landmark said to
// be passed on the left lies within landmark_distance of the path, in the
// same room, on the left of the direction of travel; the stop landmark lies
// within stop_landmark_distance of the goal. Wording varies (templates,
// synonyms, clause order, optional details, sentence splits) and uses words
// of the real R2R vocabulary, so a model has to read the instruction and
// look at the scene to follow it.
//
// A second, "speaker" style stands in for the speaker-model augmentation
// data of Tan et al. 2019 / Fried et al. 2018 used by the paper: shorter,
// lowercase, formulaic, with fewer landmarks and occasional mistakes (a
// wrong side or colour), as speaker-model output is.
//
// Positions are world frame (+Y up, metres) at the agent's feet; headings
// are radians, 0 looking along -Z, counter-clockwise (left) positive.

#include <cstdint>
#include <string>
#include <vector>

#include "common/Math.h"
#include "data/SubInstructions.h"
#include "sim/Mesh.h"
#include "world/WorldConfig.h"

namespace vln::world {

/// Who "wrote" an instruction.
enum class InstructionStyle {
  kHuman,    ///< R2R annotator style: varied and always correct
  kSpeaker,  ///< speaker-model style: short, formulaic, sometimes wrong
};

/// A side relative to the direction of travel.
enum class Side { kNone, kLeft, kRight };

/// How an instruction refers to a landmark.
enum class LandmarkRole {
  kPass,     ///< "walk past the X (on your left)"
  kBetween,  ///< "walk between the X and the Y"
  kToward,   ///< "walk towards the X" (ahead of the agent on that leg)
  kTurnAt,   ///< "turn left at the X" (near that waypoint)
  kStop,     ///< "stop next to the X"
};

/// One landmark as the text mentions it (for grounding checks).
struct LandmarkMention {
  int object_id = -1;  ///< sim::SemanticObject::id
  LandmarkRole role = LandmarkRole::kPass;
  std::string phrase;       ///< as written, e.g. "white fridge"
  Side side = Side::kNone;  ///< the side the text states, if any
  /// Index of the path leg (waypoint i to i+1) the mention refers to; for
  /// kTurnAt the waypoint index, for kStop the last waypoint.
  int leg = -1;
  /// False when the speaker style deliberately got the side or colour
  /// wrong; always true in the human style.
  bool truthful = true;
};

/// One generated instruction and what it claims.
struct GeneratedInstruction {
  std::string text;
  std::vector<LandmarkMention> landmarks;
  int goal_room = -1;  ///< index into semantics.rooms of the goal, or -1
  /// Every clause of `text` with the leg it describes (the leg holding the
  /// point of the path it is about; the last waypoint's index for the stop
  /// clause), in text order.
  std::vector<data::SubInstruction> sub_instructions;
};

/// Generates instructions for paths through one house.
class InstructionGenerator {
 public:
  /// `semantics` must outlive the generator.
  InstructionGenerator(const sim::SceneSemantics& semantics,
                       const InstructionConfig& config);

  /// `count` instructions for the path through `waypoints` (at least two;
  /// the agent starts at waypoints[0] facing `startHeading`). Human-style
  /// instructions of one call differ from each other. Deterministic for a
  /// given `seed`.
  std::vector<GeneratedInstruction> generate(
      const std::vector<Vec3f>& waypoints, float startHeading,
      InstructionStyle style, int count, uint64_t seed) const;

 private:
  const sim::SceneSemantics& semantics_;
  InstructionConfig config_;
};

/// The words an instruction may use for a room type (first = canonical),
/// e.g. "hallway" -> {"hallway", "hall", "corridor"}; unknown types map to
/// themselves.
std::vector<std::string> roomTypeWords(const std::string& type);
/// The words for an object category, e.g. "sofa" -> {"sofa", "couch"};
/// unknown categories map to themselves.
std::vector<std::string> objectCategoryWords(const std::string& category);

/// Horizontal distance (metres) from `p` to the x-z footprint of `box`; 0
/// inside it.
float footprintDistance(const Eigen::AlignedBox3f& box, const Vec3f& p);

}  // namespace vln::world
