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

With --by-first-turn it reports instead, per agent and per kind of the
instruction's first turn phrase (sharp / plain / slight left or right,
straight, turn around; the generator's words, "none" without one), where
the first leg goes and where the agent's first forward step heads, both
relative to the start heading (degrees, positive = left): the leg's median,
the opening's median and 10th-90th percentiles, how often the opening is
within 45 degrees of the leg, and how often it is on the wrong side (the
leg at least 45 degrees to one side, the opening at least 30 degrees to the
other). The first turn phrase need not describe the first leg (the words
may open with a room to leave), so the leg column says how well it does.

With --by-decision (waypoint agents whose files carry the goal oracle's
verdict, "oracle" and "end_distances" in each of "waypoint_choices": eval
writes them where the goal is known) it reports, per agent and per
decision k (all runs pooled): how many episodes reached decision k, how
often the agent's choice there was as good as the oracle's (both STOP, or a
candidate whose execution ends within --tolerance metres of the oracle's
choice's end distance to the goal), how often it was the oracle's own
choice, and in how many episodes the first choice worse than the oracle's
("the first slip") came at decision k; then how the first slips divide
into stopping early (STOP where the oracle walks on), walking on (a
candidate where the oracle STOPs) and a worse candidate.

Reads <dir>/episodes_ckpt_*_<split>.json.gz (eval's per-episode files,
one per directory: actions, positions, headings, metrics) and the split's
episodes file (reference paths). Fractions are means over an agent's
directories (seeds). Needs only the Python standard library.
"""
import argparse
import json
import math
import re
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


# The instruction generator's turn phrases (src/world/InstructionGenerator.cpp),
# most specific first; the first match in the text names the first turn.
TURN_PATTERN = re.compile(
    r"\b(?P<around>turn (all the way )?around)\b"
    r"|\b(?P<sharp>sharp|sharply) (to the )?(?P<sharp_side>left|right)\b"
    r"|\b(?P<slight>slight|slightly|veer|bear) (to the )?(?P<slight_side>left|right)\b"
    r"|\b(?P<straight>walk forward|go straight|straight ahead|head straight|move forward)\b"
    r"|\b(?P<plain_side>left|right)\b")
TURN_KINDS = ["sharp left", "left", "slight left", "straight", "slight right",
              "right", "sharp right", "turn around", "none"]


def first_turn(text):
    m = TURN_PATTERN.search(text.lower())
    if m is None:
        return "none"
    if m.group("around"):
        return "turn around"
    if m.group("sharp"):
        return "sharp " + m.group("sharp_side")
    if m.group("slight"):
        return "slight " + m.group("slight_side")
    if m.group("straight"):
        return "straight"
    return m.group("plain_side")


def instruction_texts(data, split):
    episodes, path = result_files.split_episodes(data, split, TOOL)
    out = {}
    for e in episodes:
        text = (e.get("instruction") or {}).get("instruction_text")
        if not isinstance(text, str):
            fail(f"'{path}': episode {e.get('episode_id')} has no "
                 "instruction.instruction_text (needed by --by-first-turn)")
        out[str(e["episode_id"])] = text
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


def signed_angle(a, b):
    """a - b wrapped into [-pi, pi)."""
    return (a - b + math.pi) % (2 * math.pi) - math.pi


def angle_between(a, b):
    return abs(signed_angle(a, b))


def percentile(values, q):
    ordered = sorted(values)
    return ordered[round(q * (len(ordered) - 1))]


def first_turn_rows(pattern, split, refs, texts, radius):
    """Per first-turn kind: the reference legs' and the agent's openings'
    angles relative to the start heading (degrees), over all runs."""
    legs, openings = {}, {}
    for file, episodes in result_files.run_episodes(pattern, split, TOOL):
        for e in episodes:
            want = first_leg_heading(reference_of(refs, e, file, split),
                                     radius)
            _, _, headings, actions = episode_path(e, file)
            first_forward = first_forward_index(actions, headings)
            if want is None or first_forward is None:
                continue
            kind = first_turn(texts[str(e["episode_id"])])
            start = headings[0]
            legs.setdefault(kind, []).append(
                math.degrees(signed_angle(want, start)))
            openings.setdefault(kind, []).append(
                math.degrees(signed_angle(headings[first_forward], start)))
    rows = []
    for kind in TURN_KINDS:
        if kind not in legs:
            continue
        leg, opening = legs[kind], openings[kind]
        right = sum(abs(signed_angle(math.radians(o), math.radians(g)))
                    < math.pi / 4 for g, o in zip(leg, opening))
        sided = [(g, o) for g, o in zip(leg, opening) if abs(g) >= 45]
        wrong = sum((g > 0 and o <= -30) or (g < 0 and o >= 30)
                    for g, o in sided)
        rows.append({"first turn": kind, "episodes": len(leg),
                     "leg median": statistics.median(leg),
                     "opening median": statistics.median(opening),
                     "opening p10": percentile(opening, 0.1),
                     "opening p90": percentile(opening, 0.9),
                     "opening leg right": right / len(leg),
                     "wrong side": (wrong / len(sided) if sided
                                    else float("nan"))})
    return rows


def episode_path(episode, where):
    """The episode's metrics, path positions, headings and actions; fails
    naming the episode when one is missing or they do not fit together."""
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
    return metrics, positions, headings, actions


def first_forward_index(actions, headings):
    """The step of the first forward move (its heading is the opening), or
    None when the agent never moved."""
    return next((i for i, a in enumerate(actions)
                 if a == MOVE_FORWARD and i < len(headings)), None)


def reference_of(refs, episode, where, split):
    episode_id = str(episode.get("episode_id"))
    if episode_id not in refs:
        fail(f"'{where}': episode {episode_id} is not in split {split}")
    return refs[episode_id]


def json_value(value):
    """NaN (a column that does not apply) as null: strict JSON."""
    return None if isinstance(value, float) and math.isnan(value) else value


def classify(episode, ref, radius, want, where):
    """`want`: the first leg's heading (first_leg_heading()), or None."""
    metrics, positions, headings, actions = episode_path(episode, where)
    if metrics["success"]:
        outcome = "success"
    elif metrics["oracle_success"]:
        outcome = "stopped near goal"
    else:
        fraction = nodes_passed(positions, ref, radius) / (len(ref) - 1)
        third = min(2, int(fraction * 3))
        outcome = OUTCOMES[2 + third]
    first_forward = first_forward_index(actions, headings)
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


SLIPS = ["stopped early", "walked on", "worse candidate"]


def slip(choice, tolerance, where):
    """None when the choice was as good as the goal oracle's, else its
    kind (SLIPS); raises for a choice without the oracle's verdict."""
    if "oracle" not in choice or "end_distances" not in choice:
        fail(f"{where}: a waypoint choice has no 'oracle' and "
             "'end_distances' (evaluated without the goal, or by an older "
             "eval)")
    chosen, oracle = choice.get("chosen"), choice["oracle"]
    ends = choice["end_distances"]
    if not (isinstance(chosen, int) and isinstance(oracle, int) and
            isinstance(ends, list) and
            all(d is None or isinstance(d, (int, float)) for d in ends)):
        fail(f"{where}: a waypoint choice's 'chosen', 'oracle' or "
             "'end_distances' is malformed")
    if oracle == -1:
        return None if chosen == -1 else "walked on"
    if chosen == -1:
        return "stopped early"
    if not (0 <= chosen < len(ends) and 0 <= oracle < len(ends)):
        fail(f"{where}: a waypoint choice's 'chosen' or 'oracle' is beyond "
             "its end distances")
    if ends[chosen] is not None and ends[oracle] is not None and \
            ends[chosen] <= ends[oracle] + tolerance:
        return None
    return "worse candidate"


def decision_rows(pattern, split, tolerance):
    """Per decision index (1-based): episodes reaching it, choices as good
    as the oracle's, the oracle's own choice, first slips there; and the
    first slips' kinds, over all runs."""
    reached, good, exact, first = {}, {}, {}, {}
    kinds = dict.fromkeys(SLIPS, 0)
    episodes_seen = 0
    for file, episodes in result_files.run_episodes(pattern, split, TOOL):
        for e in episodes:
            choices = e.get("waypoint_choices")
            if not isinstance(choices, list) or not choices:
                fail(f"{file}: episode {e.get('episode_id')} has no "
                     "waypoint_choices (not a waypoint agent's file)")
            episodes_seen += 1
            slipped = False
            for k, choice in enumerate(choices, start=1):
                kind = slip(choice, tolerance,
                            f"{file}: episode {e.get('episode_id')}")
                reached[k] = reached.get(k, 0) + 1
                good[k] = good.get(k, 0) + (kind is None)
                exact[k] = exact.get(k, 0) + (
                    choice["chosen"] == choice["oracle"])
                if kind is not None and not slipped:
                    slipped = True
                    first[k] = first.get(k, 0) + 1
                    kinds[kind] += 1
    rows = [{"decision": k, "reached": reached[k],
             "as good": good[k] / reached[k],
             "oracle choice": exact[k] / reached[k],
             "first slip": first.get(k, 0) / episodes_seen}
            for k in sorted(reached)]
    never = 1.0 - sum(first.values()) / episodes_seen
    slips = sum(kinds.values())
    return rows, never, {k: (v / slips if slips else float("nan"))
                         for k, v in kinds.items()}, episodes_seen


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
            ref = reference_of(refs, e, file, split)
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
    parser.add_argument("--by-first-turn", action="store_true",
                        help="the openings by the instruction's first turn "
                             "phrase instead (see above)")
    parser.add_argument("--by-decision", action="store_true",
                        help="waypoint agents' choices against the goal "
                             "oracle's, decision by decision (see above)")
    parser.add_argument("--tolerance", type=float, default=0.5,
                        help="with --by-decision, metres by which a "
                             "candidate may end farther from the goal than "
                             "the oracle's and still be as good "
                             "(default: %(default)s)")
    args = parser.parse_args()
    if not args.radius > 0:
        fail(f"--radius must be positive, got {args.radius}")
    if not args.tolerance >= 0:
        fail(f"--tolerance must be >= 0, got {args.tolerance}")
    if args.by_decision and args.by_first_turn:
        fail("--by-decision and --by-first-turn are separate reports")

    if args.by_decision:
        tables = {name: decision_rows(pattern, args.split, args.tolerance)
                  for name, pattern in args.agent}
        if args.json:
            print(json.dumps(
                {n: {"decisions": [{k: json_value(v) for k, v in r.items()}
                                   for r in rows],
                     "never slipped": never,
                     "first slips": {k: json_value(v)
                                     for k, v in kinds.items()},
                     "episodes": count}
                 for n, (rows, never, kinds, count) in tables.items()},
                indent=2, sort_keys=True))
            return
        print(f"{args.split}: choices against the goal oracle's, by decision "
              f"(as good: within {args.tolerance:g} m of the oracle's end "
              "distance; all runs pooled)")
        print("| agent | decision | reached | as good as the oracle's | "
              "the oracle's choice | first slip here |")
        print("| --- | ---: | ---: | ---: | ---: | ---: |")
        for name, (rows, never, kinds, count) in tables.items():
            for r in rows:
                print(f"| {name} | {r['decision']} | {r['reached']} | "
                      f"{r['as good']:.3f} | {r['oracle choice']:.3f} | "
                      f"{r['first slip']:.3f} |")
            print(f"| {name} | never slipped | {count} | | | {never:.3f} |")
        print()
        print("| agent | " + " | ".join(f"first slips: {k}" for k in SLIPS)
              + " |")
        print("| --- |" + " ---: |" * len(SLIPS))
        for name, (_, _, kinds, _) in tables.items():
            print(f"| {name} | " + " | ".join(
                "-" if math.isnan(kinds[k]) else f"{kinds[k]:.3f}"
                for k in SLIPS) + " |")
        return

    refs = reference_paths(args.data, args.split)
    if args.by_first_turn:
        texts = instruction_texts(args.data, args.split)
        tables = {name: first_turn_rows(pattern, args.split, refs, texts,
                                        args.radius)
                  for name, pattern in args.agent}
        if args.json:
            print(json.dumps({n: [{k: json_value(v) for k, v in row.items()}
                                  for row in rows]
                              for n, rows in tables.items()},
                             indent=2, sort_keys=True))
            return
        print(f"{args.split}: the first forward step by the instruction's "
              "first turn phrase (degrees from the start heading, + = left; "
              "all runs pooled)")
        print("| agent | first turn | episodes | leg median | opening median "
              "[10%, 90%] | opening leg right | wrong side |")
        print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
        for name, rows in tables.items():
            for r in rows:
                wrong = ("-" if math.isnan(r["wrong side"])
                         else f"{r['wrong side']:.3f}")
                print(f"| {name} | {r['first turn']} | {r['episodes']} | "
                      f"{r['leg median']:.0f} | {r['opening median']:.0f} "
                      f"[{r['opening p10']:.0f}, {r['opening p90']:.0f}] | "
                      f"{r['opening leg right']:.3f} | {wrong} |")
        return
    results = {}
    for name, pattern in args.agent:
        rates, runs, episodes = agent_rates(pattern, args.split, refs,
                                            args.radius)
        results[name] = dict(rates, runs=runs, episodes=episodes)
    if args.json:
        print(json.dumps({n: {k: json_value(v) for k, v in r.items()}
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
