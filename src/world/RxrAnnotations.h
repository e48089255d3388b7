#pragma once
// RxR-style annotations of a generated instruction: per-word timestamps
// aligned to the path (RxR's timed_instruction) and an en-IN variant of an
// en-US text.
//
// Timing model: the annotator walks the path at a constant speed (m/s),
// pausing at the start and at every intermediate waypoint to look around,
// and speaks each landmark or turn phrase when the walk reaches the part of
// the path it describes: a turn at waypoint i on arriving there, a landmark
// passed on leg i when leaving waypoint i, the stop phrase when starting
// the last leg. Words between these anchors are spread evenly in time; the
// first word starts at 0 and the last ends by the end of the walk.

#include <string>
#include <string_view>
#include <vector>

#include "common/Math.h"
#include "data/Episode.h"
#include "world/InstructionGenerator.h"

namespace vln::world {

/// When the walk reaches each waypoint and leaves it again (seconds from the
/// start): arrival[0] = 0, departure[i] = arrival[i] + pause (0 at the
/// goal), arrival[i+1] = departure[i] + |w[i+1] - w[i]| / speed.
struct WalkTimes {
  std::vector<double> arrival;
  std::vector<double> departure;
  /// arrival.back(): the length of the recording, seconds.
  double duration() const { return arrival.empty() ? 0.0 : arrival.back(); }
};

/// WalkTimes of `waypoints` (world frame, metres; at least one) at `speed`
/// m/s (> 0) with `pause` seconds (>= 0) at the start and every
/// intermediate waypoint.
WalkTimes walkTimes(const std::vector<Vec3f>& waypoints, double speed,
                    double pause);

/// The words of `instruction.text` (split at white space, punctuation around
/// a word dropped) with start and end times in [0, times.duration()]:
/// non-decreasing, start <= end <= next start, in whole milliseconds. Landmark
/// phrases of `instruction.landmarks` found in the text anchor their first word
/// at the time of the part of the path they describe (file comment).
std::vector<data::TimedWord> timeInstruction(
    const GeneratedInstruction& instruction, const WalkTimes& times);

/// An en-IN rendering of an en-US instruction: the same words but a few
/// Indian-English lexical choices ("washroom", "drawing room", "proceed",
/// ...), one word for one word so that timed words map one to one. Case of
/// a first letter is kept.
std::string toIndianEnglish(std::string_view text);

}  // namespace vln::world
