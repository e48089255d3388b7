"""Reading eval's result folders and a split's episodes file, shared by the
analysis scripts (per_house_success.py, failure_stages.py). Errors end the
program with a message that names the calling script and the file.
Needs only the Python standard library.
"""
import glob
import gzip
import json
import os
import sys


def fail(tool, message):
    sys.exit(f"{tool}: {message}")


def load_json_gz(path, tool):
    try:
        with gzip.open(path, "rt") as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        fail(tool, f"cannot read '{path}': {e}")


def split_episodes(data, split, tool):
    """The episodes of <data>/<split>/<split>.json.gz and that path."""
    path = os.path.join(data, split, f"{split}.json.gz")
    episodes = load_json_gz(path, tool).get("episodes")
    if not isinstance(episodes, list):
        fail(tool, f"'{path}' has no 'episodes' list")
    return episodes, path


def run_episodes(pattern, split, tool):
    """[(file, episodes)] of every directory matching `pattern` (one run,
    e.g. one seed, each), from its single episodes_ckpt_*_<split>.json.gz."""
    dirs = sorted(d for d in glob.glob(pattern) if os.path.isdir(d))
    if not dirs:
        fail(tool, f"no directory matches '{pattern}'")
    runs = []
    for d in dirs:
        files = glob.glob(os.path.join(d, f"episodes_ckpt_*_{split}.json.gz"))
        if len(files) != 1:
            fail(tool, f"'{d}' must hold exactly one "
                       f"episodes_ckpt_*_{split}.json.gz, found {len(files)}")
        episodes = load_json_gz(files[0], tool).get("episodes")
        if not isinstance(episodes, list):
            fail(tool, f"'{files[0]}' has no 'episodes' list")
        runs.append((files[0], episodes))
    return runs
