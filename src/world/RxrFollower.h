#pragma once
// Ground-truth actions of an RxR walk for the RxR-Habitat agent (turn 30
// degrees, no sliding). The shortest-path follower (sim/Follower.h) moves
// forward while the path is within turn_angle of its heading; without
// sliding, such a step towards a door frame or a table corner is blocked and
// the follower would repeat it forever. This follower then takes the
// shortest unblocked detour instead: one or two turns either way and a
// step, whichever leaves it geodesically nearest to the waypoint. Every
// recorded action is one the agent took, so replaying them from the start
// state reproduces the recorded locations exactly.

#include <vector>

#include "data/NodeTransfer.h"
#include "sim/Agent.h"
#include "sim/NavMesh.h"

namespace vln::world {

/// data::checkNavigability() for `waypoints` (world frame, metres; at least
/// two, on `navmesh`) from `startHeading` radians, with the recovery of the
/// file comment when a MOVE_FORWARD is blocked. The same failures, caps and
/// result layout (actions end with one STOP).
data::NavigabilityResult followRxrWalk(const sim::NavMesh& navmesh,
                                       const sim::AgentConfig& agent,
                                       const data::TransferConfig& config,
                                       const std::vector<Vec3f>& waypoints,
                                       float startHeading);

}  // namespace vln::world
