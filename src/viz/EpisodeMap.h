#pragma once
// Top-down maps of evaluated episodes, like the paper's qualitative figure:
// the reference path (blue), the agent's path (orange), the start (green),
// the goal (red) with the success circle around it, and the agent's final
// pose, on a sim::TopDownMap of the start's floor; and the picture people
// see: the map over a footer with a legend and a scale bar. Maps, videos,
// TensorBoard images and the HTML report all draw through here.

#include <string>
#include <vector>

#include "rollout/Metrics.h"
#include "sim/Scene.h"
#include "sim/TopDownMap.h"
#include "viz/Image.h"

namespace vln::viz {

/// Colours of the drawings (RGB).
inline constexpr sim::Rgb8 kReferenceColor = {30, 100, 220};
inline constexpr sim::Rgb8 kAgentColor = {245, 130, 20};
inline constexpr sim::Rgb8 kStartColor = {20, 170, 40};
inline constexpr sim::Rgb8 kGoalColor = {220, 30, 30};
/// A waypoint agent's candidates and the ones it chose.
inline constexpr sim::Rgb8 kCandidateColor = {150, 150, 150};
inline constexpr sim::Rgb8 kChosenColor = {150, 40, 200};

/// How large a map is drawn: `meters_per_pixel` when > 0, else the scale at
/// which the floor's map is `long_side` pixels on its long side.
struct MapStyle {
  int long_side = 1024;
  float meters_per_pixel = 0.0f;

  /// The scale for the floor of `scene` nearest `floorY`, metres per pixel.
  float metersPerPixel(const sim::Scene& scene, float floorY) const;
};

/// A top-down map of `scene` on the floor of the record's start with the
/// reference path, the agent path, start, goal and success circle (goal
/// and circle only when `hasGoal`) and the agent's final pose; for a
/// waypoint agent also every decision's candidates (grey) and a line from
/// where it stood to the one it chose (purple).
sim::TopDownMap drawEpisodeMap(const sim::Scene& scene,
                               const rollout::EpisodeRecord& record,
                               bool hasGoal, float successDistance,
                               const MapStyle& style = {});

/// What the legend explains.
struct MapLegend {
  bool goal = true;               ///< goal marker and success circle drawn
  float success_distance = 3.0f;  ///< their radius, metres
  bool agent_path = true;         ///< agent path and final pose drawn
  bool waypoints = false;         ///< a waypoint agent's candidates and choices
};

/// The legend of a map drawn from `record`: goal and circle when `hasGoal`,
/// the waypoint entries when it holds waypoint choices.
MapLegend mapLegendOf(const rollout::EpisodeRecord& record, bool hasGoal,
                      float successDistance);

/// A scale bar: its length in metres (1, 2 or 5 times a power of ten) and
/// in pixels, at most `maxPixels` long.
struct ScaleBar {
  float meters = 0.0f;
  int pixels = 0;
};
ScaleBar chooseScaleBar(float metersPerPixel, int maxPixels);

/// Height in pixels of the footer under a map `width` pixels wide at
/// `metersPerPixel` (the legend wraps onto more rows on narrow maps).
int footerHeight(int width, float metersPerPixel, const MapLegend& legend);

/// The map over its footer: legend entries on the left, the scale bar on
/// the right.
Image mapPicture(const sim::TopDownMap& map, const MapLegend& legend);

/// The map alone as an Image (no footer).
Image mapImage(const sim::TopDownMap& map);

/// File name of episode `episodeId`'s map: "<prefix>episode_<id>_map.png".
std::string mapFileName(const std::string& prefix,
                        const std::string& episodeId);

}  // namespace vln::viz
