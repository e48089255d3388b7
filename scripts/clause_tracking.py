#!/usr/bin/env python3
"""How well a waypoint agent's clause tracker (model.clause_tracker) keeps
its place in the instruction, per agent.

At every decision the tracker's pointer names the rule clause the agent
reads from ("clause" in each of eval's "waypoint_choices"). This compares it
with the clause an oracle would name there: the rule clause holding the
first word of the clauses describing the reference path's leg ahead of the
agent (data::clausesAhead() of the split's sub-instruction file, the leg
found half a metre past the agent's projection onto the path), or the last
rule clause where no described leg is ahead: the target the tracker is
trained towards (train::clauseTargets()). It reports, per agent and per
decision k (all runs pooled), how many decisions there were, how often the
pointer was on the oracle's clause, behind it and ahead of it, and for all
decisions the share within `window - 1` clauses behind (the oracle's first
word then among the words read, for model.clause_window = `window`).

The rule (data::ruleClauses()) and the tokeniser (data::tokenize()) are
restated here; the split's sub-instruction file is written by
`vlnce-data generate --set splits.evaluation_sub_instructions=true`.

    /usr/bin/python3 scripts/clause_tracking.py --split val_unseen \\
        --data data/datasets/procedural_legs --window 2 \\
        --agent tracker 'results/x/wp_ct_w2_s*'

Reads <dir>/episodes_ckpt_*_<split>.json.gz (one per directory), the
split's episodes and <split>_sub_instructions.json.gz. Needs only the
Python standard library.
"""
import argparse
import math
import os
import re

import result_files

TOOL = "clause_tracking.py"
LEG_LOOKAHEAD = 0.5  # data::kLegLookahead


def fail(message):
    result_files.fail(TOOL, message)


def tokenize(text):
    """data::tokenize() for ASCII text: lower case, "'s" split off, commas
    and question marks dropped, runs of [\\w-] and of the rest, stripped."""
    text = text.lower().replace("'s", " 's").replace(",", "").replace("?", "")
    return [t.strip() for t in re.findall(r"[\w-]+|[^\w-]+", text) if t.strip()]


def rule_clauses(text):
    """data::ruleClauses(): [(first, last)] token ranges."""
    cuts, previous = [0], ""
    for m in re.finditer(r"[.,;:!?]|[A-Za-z0-9'_-]+", text):
        word = m.group(0)
        if len(word) == 1 and word in ".,;:!?":
            cuts.append(m.end())
            previous = ""
            continue
        lower = word.lower()
        if lower == "and" or (lower == "then" and previous != "and"):
            cuts.append(m.start())
        previous = lower
    cuts.append(len(text))
    bounds = [len(tokenize(text[:c])) for c in cuts]
    return [(bounds[k], bounds[k + 1]) for k in range(len(bounds) - 1)
            if bounds[k + 1] > bounds[k]]


def upcoming_leg(path, position):
    """data::upcomingLeg() with kLegLookahead."""
    best, along, start, leg_start = math.inf, 0.0, 0.0, [0.0]
    for i in range(len(path) - 1):
        a, b = path[i], path[i + 1]
        d = [b[j] - a[j] for j in range(3)]
        length = math.sqrt(sum(x * x for x in d))
        t = 0.0
        if length > 0:
            t = sum((position[j] - a[j]) * d[j] for j in range(3)) / length**2
            t = min(1.0, max(0.0, t))
        distance = math.dist([a[j] + t * d[j] for j in range(3)], position)
        if distance < best:
            best, along = distance, start + t * length
        start += length
        leg_start.append(start)
    ahead = along + LEG_LOOKAHEAD
    if ahead >= start:
        return len(path) - 1
    return max(k for k, s in enumerate(leg_start) if s <= ahead)


def oracle_clause(text, spans, path, position):
    """The rule clause holding the first word of data::clausesAhead()."""
    rule = rule_clauses(text)
    leg = upcoming_leg(path, position)
    legs = [s["leg"] for s in spans if s["leg"] >= leg]
    if not legs:
        return len(rule) - 1
    first = min(len(tokenize(text[:s["begin"]])) for s in spans
                if s["leg"] == min(legs))
    holding = 0
    for k, (a, _) in enumerate(rule):
        if a <= first:
            holding = k
    return holding


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--split", default="val_unseen")
    parser.add_argument("--data", required=True,
                        help="dataset folder with the split's sub-instructions")
    parser.add_argument("--window", type=int, default=2,
                        help="model.clause_window of the agents")
    parser.add_argument("--agent", nargs=2, action="append", required=True,
                        metavar=("NAME", "GLOB"))
    args = parser.parse_args()

    episodes, _ = result_files.split_episodes(args.data, args.split, TOOL)
    by_id = {str(e["episode_id"]): e for e in episodes}
    sub_path = os.path.join(args.data, args.split,
                            f"{args.split}_sub_instructions.json.gz")
    if not os.path.exists(sub_path):
        fail(f"'{sub_path}' does not exist (vlnce-data generate --set "
             "splits.evaluation_sub_instructions=true writes it)")
    spans = result_files.load_json_gz(sub_path, TOOL)

    print(f"| agent | decision | n | on the oracle's clause | behind | ahead |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for name, pattern in args.agent:
        rows = {}  # decision -> [n, on, behind, ahead]
        within, total = 0, 0
        for path, results in result_files.run_episodes(pattern, args.split,
                                                       TOOL):
            for r in results:
                eid = str(r.get("episode_id"))
                if eid not in by_id or eid not in spans:
                    fail(f"'{path}': episode {eid} is not in the split's "
                         "episodes or sub-instructions")
                e = by_id[eid]
                text = e["instruction"]["instruction_text"]
                for k, c in enumerate(r.get("waypoint_choices", [])):
                    if "clause" not in c:
                        fail(f"'{path}': episode {eid} decision {k} has no "
                             "'clause' (not a model.clause_tracker agent?)")
                    want = oracle_clause(text, spans[eid],
                                         e["reference_path"], c["position"])
                    got = c["clause"]
                    row = rows.setdefault(min(k, 6), [0, 0, 0, 0])
                    row[0] += 1
                    row[1] += got == want
                    row[2] += got < want
                    row[3] += got > want
                    total += 1
                    within += want - args.window < got <= want
        for k in sorted(rows):
            n, on, behind, ahead = rows[k]
            label = str(k) if k < 6 else "6+"
            print(f"| {name} | {label} | {n} | {on / n:.3f} | "
                  f"{behind / n:.3f} | {ahead / n:.3f} |")
        n = sum(r[0] for r in rows.values())
        on = sum(r[1] for r in rows.values())
        print(f"| {name} | all | {n} | {on / max(n, 1):.3f} | "
              f"{sum(r[2] for r in rows.values()) / max(n, 1):.3f} | "
              f"{sum(r[3] for r in rows.values()) / max(n, 1):.3f} |")
        print(f"\n{name}: the oracle's first word read (pointer within "
              f"{args.window - 1} clause(s) behind it) at "
              f"{within / max(total, 1):.3f} of {total} decisions\n")


if __name__ == "__main__":
    main()
