#!/usr/bin/env python3
"""Where along the reference path agents go wrong, per agent.

Success rate says how often an agent arrives, not where the others fail.
This sorts every episode of a split into one outcome:

  success            stopped within the success distance of the goal
  stopped near goal  came within it at some step (oracle success) but
                     stopped elsewhere: the route was right, the stop not
  lost in 1st third  left the reference path before passing a third of its
  lost in 2nd third  nodes, before two thirds, or later: "passing" node k
  lost in 3rd third  means coming within --radius metres of it after the
                     nodes before it, in order

and reports, separately, how often the agent's first forward step heads
within 45 degrees of the path's first leg (the direction from the start to
the first reference node more than --radius away): how well it reads the
instruction's opening turn.

For a waypoint agent (files with "waypoint_choices") two more columns say
whether its first decision was offered a candidate within 45 degrees of the
first leg ("opening offered"), and how often, when it was, the agent's
opening was right ("right when offered", among episodes where it moved):
a wrong opening is then the predictor's miss or the policy's choice. Other
agents show "-".

    /usr/bin/python3 scripts/failure_stages.py --split val_unseen \\
        --agent cma 'results/x/main_ft/seed*' \\
        --agent no-instruction 'results/x/main_noinstr/seed*'

Reads <dir>/episodes_ckpt_*_<split>.json.gz (eval's per-episode files,
one per directory: actions, positions, headings, metrics) and the split's
episodes file (reference paths). Fractions are means over an agent's
directories (seeds). Needs only the Python standard library.
"""
import argparse
import json
import math
import statistics

import result_files

TOOL = "failure_stages.py"

OUTCOMES = ["success", "stopped near goal", "lost in 1st third",
            "lost in 2nd third", "lost in 3rd third"]
MOVE_FORWARD = 1


def fail(message):
    result_files.fail(TOOL, message)


def reference_paths(data, split):
    episodes, path = result_files.split_episodes(data, split, TOOL)
    out = {}
    for e in episodes:
        ref = e.get("reference_path")
        if not isinstance(ref, list) or len(ref) < 2:
            fail(f"'{path}': episode {e.get('episode_id')} has no "
                 "reference_path of two or more points")
        out[str(e["episode_id"])] = ref
    return out


def planar_distance(a, b):
    return math.hypot(a[0] - b[0], a[2] - b[2])


def nodes_passed(positions, ref, radius):
    """Index of the last reference node passed in order."""
    k = 0
    for p in positions:
        while k + 1 < len(ref) and math.dist(p, ref[k + 1]) < radius:
            k += 1
    return k


def first_leg_heading(ref, radius):
    start = ref[0]
    for node in ref[1:]:
        if planar_distance(node, start) > radius:
            # Habitat's convention: heading h faces (-sin h, 0, -cos h)
            return math.atan2(-(node[0] - start[0]), -(node[2] - start[2]))
    return None


def angle_between(a, b):
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


def classify(episode, ref, radius, want, where):
    """`want`: the first leg's heading (first_leg_heading()), or None."""
    metrics = episode.get("metrics", {})
    path = episode.get("path", {})
    positions = path.get("positions")
    headings = path.get("headings")
    actions = episode.get("actions")
    if not (isinstance(positions, list) and positions and
            isinstance(headings, list) and len(headings) == len(positions) and
            isinstance(actions, list) and "success" in metrics and
            "oracle_success" in metrics):
        fail(f"{where}: episode {episode.get('episode_id')} lacks "
             "metrics.success/oracle_success, path.positions/headings of "
             "equal length or actions")
    if metrics["success"]:
        outcome = "success"
    elif metrics["oracle_success"]:
        outcome = "stopped near goal"
    else:
        fraction = nodes_passed(positions, ref, radius) / (len(ref) - 1)
        third = min(2, int(fraction * 3))
        outcome = OUTCOMES[2 + third]
    first_forward = next((i for i, a in enumerate(actions)
                          if a == MOVE_FORWARD and i < len(headings)), None)
    if want is None or first_forward is None:
        opening = None  # no leg to compare, or the agent never moved
    else:
        opening = angle_between(headings[first_forward], want) < math.pi / 4
    return outcome, opening


def opening_offered(episode, want, where):
    """Whether the first waypoint decision offered a candidate within 45
    degrees of the first leg; None for low-level agents or no leg."""
    choices = episode.get("waypoint_choices")
    if not choices or want is None:
        return None
    first = choices[0]
    position, candidates = first.get("position"), first.get("candidates")
    if not (isinstance(position, list) and len(position) == 3 and
            isinstance(candidates, list) and
            all(isinstance(c, list) and len(c) == 3 for c in candidates)):
        fail(f"{where}: episode {episode.get('episode_id')} has a "
             "waypoint_choices[0] without position and candidates [x, y, z]")
    for c in candidates:
        heading = math.atan2(-(c[0] - position[0]), -(c[2] - position[2]))
        if angle_between(heading, want) < math.pi / 4:
            return True
    return False


def agent_rates(pattern, split, refs, radius):
    runs = result_files.run_episodes(pattern, split, TOOL)
    per_run = []
    for file, episodes in runs:
        if not episodes:
            fail(f"'{file}' has no episodes")
        counts = dict.fromkeys(OUTCOMES, 0)
        opening_right, opening_judged = 0, 0
        offered, offer_judged = 0, 0
        right_when_offered, offered_judged = 0, 0
        for e in episodes:
            episode = str(e.get("episode_id"))
            if episode not in refs:
                fail(f"'{file}': episode {episode} is not in split {split}")
            ref = refs[episode]
            want = first_leg_heading(ref, radius)
            outcome, opening = classify(e, ref, radius, want, file)
            counts[outcome] += 1
            if opening is not None:
                opening_judged += 1
                opening_right += opening
            offer = opening_offered(e, want, file)
            if offer is not None:
                offer_judged += 1
                offered += offer
                if offer and opening is not None:
                    offered_judged += 1
                    right_when_offered += opening
        rates = {k: v / len(episodes) for k, v in counts.items()}
        rates["opening"] = (opening_right / opening_judged
                            if opening_judged else float("nan"))
        rates["offered"] = (offered / offer_judged if offer_judged
                            else float("nan"))
        rates["right when offered"] = (right_when_offered / offered_judged
                                       if offered_judged else float("nan"))
        rates["episodes"] = len(episodes)
        per_run.append(rates)
    keys = OUTCOMES + ["opening", "offered", "right when offered"]
    return ({k: statistics.mean(r[k] for r in per_run) for k in keys},
            len(runs), per_run[0]["episodes"])


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--split", required=True)
    parser.add_argument("--data", default="data/datasets/procedural",
                        help="the dataset directory (default: %(default)s)")
    parser.add_argument("--radius", type=float, default=1.0,
                        help="metres within which a reference node counts "
                             "as passed (default: %(default)s)")
    parser.add_argument("--agent", nargs=2, action="append", required=True,
                        metavar=("NAME", "GLOB"),
                        help="an agent and its result directories (seeds)")
    parser.add_argument("--json", action="store_true",
                        help="print the fractions as JSON")
    args = parser.parse_args()
    if not args.radius > 0:
        fail(f"--radius must be positive, got {args.radius}")

    refs = reference_paths(args.data, args.split)
    results = {}
    for name, pattern in args.agent:
        rates, runs, episodes = agent_rates(pattern, args.split, refs,
                                            args.radius)
        results[name] = dict(rates, runs=runs, episodes=episodes)
    if args.json:
        # NaN (not a waypoint agent) as null: strict JSON
        print(json.dumps({n: {k: (None if isinstance(v, float) and
                                  math.isnan(v) else v)
                              for k, v in r.items()}
                          for n, r in results.items()},
                         indent=2, sort_keys=True))
        return
    print(f"{args.split}: fraction of episodes by outcome (mean over each "
          f"agent's runs; reference nodes passed within {args.radius:g} m)")
    columns = OUTCOMES + ["opening leg right", "opening offered",
                          "right when offered"]
    print("| agent (runs x episodes) | " + " | ".join(columns) + " |")
    print("| --- |" + " ---: |" * len(columns))
    for name, r in results.items():
        cells = [("-" if math.isnan(r[k]) else f"{r[k]:.3f}")
                 for k in OUTCOMES + ["opening", "offered",
                                      "right when offered"]]
        print(f"| {name} ({r['runs']} x {r['episodes']}) | "
              + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
