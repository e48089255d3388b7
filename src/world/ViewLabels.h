#pragma once
// What a view shows, in the words instructions use: the object categories in
// view, their colours and the type of the room the camera stands in, read
// from a semantic render and the house's semantics. The targets of the RGB
// encoder's scene-recognition pretraining (train/SemanticPretrainer.h), and,
// as viewLabelFeatures(), what a perfect recogniser would hand the waypoint
// agent (waypoint_agent.view_labels, a diagnostic: rollout/WaypointAgent.h).

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "common/Math.h"
#include "sim/Agent.h"
#include "sim/Panorama.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"

namespace vln::world {

/// The labels of one view.
struct ViewLabels {
  int room = -1;  ///< index into houseRoomTypes()
  /// [houseObjectCategories().size()] 0/1: a category in view.
  std::vector<uint8_t> categories;
  /// [houseColorNames().size()] 0/1: the colour of an object in view.
  std::vector<uint8_t> colors;
};

/// Labels of the view whose semantic render is `objectIds` (object id per
/// pixel, -1 for none) taken at feet position `position` (world frame) in a
/// house with `semantics`: an object is in view when it covers at least
/// `minFraction` of the pixels. room is -1 when the position is in no room.
/// Throws std::invalid_argument naming the object (or room) whose
/// category, colour (or type) is not in the generator's vocabulary.
ViewLabels labelView(const sim::SceneSemantics& semantics,
                     std::span<const int32_t> objectIds, const Vec3f& position,
                     float minFraction);

/// Numbers per view of viewLabelFeatures(): categories, colours, room types
/// (the order of the pretraining's heads).
int64_t viewLabelSize();

/// The labels of each view of the panorama `config` describes for an agent
/// at `agent`, each as viewLabelSize() numbers: the categories' and colours'
/// 0/1, then the room type one-hot (all 0 outside every room). View k is
/// rendered with the panorama's RGB camera at panoramaViewHeading(agent.
/// heading, k, num_views), as PanoramaRenderer renders it. Returns
/// [num_views * viewLabelSize()], view-major. Throws what labelView() and
/// the renderer throw.
std::vector<float> viewLabelFeatures(sim::Renderer& renderer,
                                     const sim::SceneSemantics& semantics,
                                     const sim::AgentState& agent,
                                     const sim::PanoramaConfig& config,
                                     float minFraction);

/// Label groups of goalLabels(): what kind of label an instruction names.
inline constexpr float kGoalCategory = 1.0f;
inline constexpr float kGoalColor = 2.0f;
inline constexpr float kGoalRoom = 3.0f;

/// Which of viewLabelFeatures()' labels the goal clause of `instruction`
/// names: the last clause of data::ruleClauses() that names an object
/// category or a room type (R2R-style instructions end on where to stop,
/// "... and wait by the grey tub"). Returns [viewLabelSize()], 0 for a label
/// it does not name, else the label's group: kGoalCategory for a category
/// named by any of objectCategoryWords(), kGoalColor for a colour,
/// kGoalRoom for a room type named by any of roomTypeWords(); whole tokens
/// of data::tokenize() are matched, so "tub" names the bathtub and "table"
/// both tables. All 0 when no clause names a category or a room.
std::vector<float> goalLabels(std::string_view instruction);

}  // namespace vln::world
