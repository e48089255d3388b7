#!/usr/bin/env python3
"""Cosine similarity of word pairs in a dataset's GloVe rows.

Usage: scripts/embedding_similarity.py [DATA_DIR] [a:b ...]

DATA_DIR holds embeddings.json.gz (rows in vocabulary order) and
train/train.json.gz (whose instruction_vocab.word_list names the rows);
default data/datasets/procedural. Without pairs it prints the pairs an
instruction follower must tell apart (directions, rooms, objects, colours).
"""
import gzip
import json
import math
import sys


def main(argv):
    root = argv[1] if len(argv) > 1 and ":" not in argv[1] else "data/datasets/procedural"
    pairs = [a for a in argv[1:] if ":" in a] or [
        "left:right", "bedroom:kitchen", "lamp:plant", "yellow:green", "turn:walk"]
    with gzip.open(f"{root}/embeddings.json.gz", "rt") as f:
        rows = json.load(f)
    with gzip.open(f"{root}/train/train.json.gz", "rt") as f:
        words = json.load(f)["instruction_vocab"]["word_list"]
    if len(rows) != len(words):
        sys.exit(f"{root}: {len(rows)} embedding rows but {len(words)} words")
    index = {w: i for i, w in enumerate(words)}
    for pair in pairs:
        a, b = pair.split(":", 1)
        missing = [w for w in (a, b) if w not in index]
        if missing:
            sys.exit(f"{root}: not in the vocabulary: {', '.join(missing)}")
        x, y = rows[index[a]], rows[index[b]]
        dot = sum(p * q for p, q in zip(x, y))
        norm = math.sqrt(sum(p * p for p in x) * sum(q * q for q in y))
        print(f"{a} {b} {dot / norm:.3f}")


if __name__ == "__main__":
    main(sys.argv)
