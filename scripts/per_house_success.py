#!/usr/bin/env python3
"""Success rate (and SPL) per house of one split for two or more agents,
and the paired difference of the first two with houses as the unit.

The intervals of docs/results.md are over training seeds; every seed is
scored on the same few houses (6 per evaluation split in the default
world), so those intervals say nothing about how much a result depends on
which houses the split happens to hold. Here each house is one
observation: the mean over the given result directories (seeds) of the
agent's success in that house's episodes.

    /usr/bin/python3 scripts/per_house_success.py --split val_unseen \
        --agent waypoint 'results/x/wp/seed*' \
        --agent low-level 'results/x/main_ft/seed*'

Reads <dir>/episodes_ckpt_*_<split>.json.gz (eval's per-episode files; one
per directory) and the split's episodes file for each episode's scene.
Needs only the Python standard library.
"""
import argparse
import math
import os
import statistics

import result_files

TOOL = "per_house_success.py"

# two-sided 95% Student t quantiles for 1..30 degrees of freedom
T95 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262,
       2.228, 2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093,
       2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045,
       2.042]


def house_of(scene_id):
    # "house_003_57ea68a3/house_003_57ea68a3.glb" -> "house_003_57ea68a3"
    return os.path.basename(os.path.dirname(scene_id)) or scene_id


def scenes(data, split):
    episodes, _ = result_files.split_episodes(data, split, TOOL)
    return {str(e["episode_id"]): house_of(e["scene_id"]) for e in episodes}


def per_house(pattern, split, scene_of):
    """{house: [mean success over the runs], ...} and the same for SPL."""
    runs = result_files.run_episodes(pattern, split, TOOL)
    success, spl = {}, {}
    for file, episodes in runs:
        by_house_s, by_house_p = {}, {}
        for e in episodes:
            episode = str(e["episode_id"])
            if episode not in scene_of:
                result_files.fail(TOOL, f"'{file}': episode {episode} is not "
                                        f"in split {split}")
            h = scene_of[episode]
            by_house_s.setdefault(h, []).append(e["metrics"]["success"])
            by_house_p.setdefault(h, []).append(e["metrics"]["spl"])
        for h in by_house_s:
            success.setdefault(h, []).append(statistics.mean(by_house_s[h]))
            spl.setdefault(h, []).append(statistics.mean(by_house_p[h]))
    return ({h: statistics.mean(v) for h, v in success.items()},
            {h: statistics.mean(v) for h, v in spl.items()}, len(runs))


def interval(values):
    n = len(values)
    mean = statistics.mean(values)
    if n < 2:
        return mean, float("nan")
    return mean, T95[min(n - 1, 30) - 1] * statistics.stdev(values) / math.sqrt(n)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default="data/datasets/procedural",
                        help="dataset root holding <split>/<split>.json.gz")
    parser.add_argument("--split", required=True)
    parser.add_argument("--agent", nargs=2, action="append", required=True,
                        metavar=("NAME", "GLOB"),
                        help="an agent's result directories (one per seed)")
    args = parser.parse_args()
    scene_of = scenes(args.data, args.split)
    agents = [(name, *per_house(pattern, args.split, scene_of))
              for name, pattern in args.agent]
    houses = sorted(set().union(*(a[1].keys() for a in agents)))
    print(f"{args.split}: success rate / SPL per house, mean over each "
          f"agent's runs")
    print("| house | " + " | ".join(f"{a[0]} ({a[3]} runs)" for a in agents)
          + " |")
    print("| --- |" + " --- |" * len(agents))
    for h in houses:
        cells = [f"{a[1][h]:.3f} / {a[2][h]:.3f}" if h in a[1] else "-"
                 for a in agents]
        print(f"| {h} | " + " | ".join(cells) + " |")
    if len(agents) >= 2:
        first, second = agents[0], agents[1]
        common = [h for h in houses if h in first[1] and h in second[1]]
        for metric, index in (("SR", 1), ("SPL", 2)):
            diffs = [first[index][h] - second[index][h] for h in common]
            mean, half = interval(diffs)
            print(f"{first[0]} - {second[0]} {metric}, houses as the unit "
                  f"(n = {len(common)}): {mean:+.3f} +/- {half:.3f} "
                  f"(95% t interval)")


if __name__ == "__main__":
    main()
