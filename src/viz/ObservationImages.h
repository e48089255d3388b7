#pragma once
// What the pictures of an episode (videos, TensorBoard GIFs, report frames)
// show of an observation and of the agent's progress, in one place.

#include <cstdint>
#include <vector>

#include "data/Episode.h"
#include "sim/Simulator.h"

namespace vln::viz {

/// The depth value shown as white: 1 when the simulator normalises depth to
/// [0, 1], else its max_depth (metres).
float depthDisplayScale(const sim::Simulator& simulator);

/// The observation's depth as grey levels round(255 * clamp(d / scale, 0,
/// 1)), one byte per pixel, row-major.
std::vector<uint8_t> depthGreyLevels(const sim::Observation& observation,
                                     float scale);

/// Geodesic distance (metres) from `position` to the episode's first goal
/// on the simulator's navmesh; -1 when the episode has no goal (a test
/// split).
float distanceToGoal(const sim::Simulator& simulator,
                     const data::Episode& episode, const Vec3f& position);

}  // namespace vln::viz
