#!/usr/bin/env python3
"""Reads the observation dumps of `eval --dump DIR` (docs/dumps.md).

Standard library only: PNGs (8-bit RGB, 16-bit grey, the two kinds a dump
holds, plus 8-bit grey/RGBA) are decoded here with zlib. JPEG RGB frames
(`--dump-format jpg`) need Pillow. When numpy is importable, images come
back as arrays (RGB [T, H, W, 3] uint8, depth [T, H, W] uint16 millimetres);
otherwise as nested lists.

    from read_observation_dump import list_episodes, load_episode
    for folder in list_episodes("dumps", "val_unseen"):
        ep = load_episode(folder)
        ep["episode"]["instruction"]["text"], ep["rgb"].shape, ep["actions"]

Command line: prints a JSON summary of one episode folder.

    python3 scripts/read_observation_dump.py dumps/val_unseen/17 [--no-numpy]
"""

import argparse
import array
import json
import os
import struct
import sys
import zlib

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# channels of the PNG colour types decoded here: grey, RGB, grey+alpha, RGBA
CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}


class DumpError(Exception):
    """A dump file that cannot be read (names the file)."""


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def _unfilter(data, height, stride, bpp, path):
    """Undoes the per-row PNG filters; returns the raw pixel bytes."""
    out = bytearray(height * stride)
    prev = bytearray(stride)
    pos = 0
    for y in range(height):
        if pos + 1 + stride > len(data):
            raise DumpError(f"{path}: image data ends early (row {y})")
        kind = data[pos]
        row = bytearray(data[pos + 1:pos + 1 + stride])
        pos += 1 + stride
        if kind == 1:  # Sub
            for i in range(bpp, stride):
                row[i] = (row[i] + row[i - bpp]) & 0xFF
        elif kind == 2:  # Up
            row = bytearray((r + p) & 0xFF for r, p in zip(row, prev))
        elif kind == 3:  # Average
            for i in range(stride):
                left = row[i - bpp] if i >= bpp else 0
                row[i] = (row[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif kind == 4:  # Paeth
            for i in range(stride):
                left = row[i - bpp] if i >= bpp else 0
                upleft = prev[i - bpp] if i >= bpp else 0
                row[i] = (row[i] + _paeth(left, prev[i], upleft)) & 0xFF
        elif kind != 0:
            raise DumpError(f"{path}: unknown PNG filter {kind} in row {y}")
        out[y * stride:(y + 1) * stride] = row
        prev = row
    return out


def read_png(path):
    """Decodes a non-interlaced 8- or 16-bit PNG.

    Returns (width, height, channels, samples): samples is a flat
    array.array of the pixel values in row-major order, 'B' for 8-bit and
    'H' (native byte order) for 16-bit images.
    """
    with open(path, "rb") as f:
        blob = f.read()
    if not blob.startswith(PNG_SIGNATURE):
        raise DumpError(f"{path}: not a PNG file")
    pos = len(PNG_SIGNATURE)
    header = None
    idat = []
    while pos + 8 <= len(blob):
        (length,) = struct.unpack(">I", blob[pos:pos + 4])
        kind = blob[pos + 4:pos + 8]
        body = blob[pos + 8:pos + 8 + length]
        if len(body) != length:
            raise DumpError(f"{path}: truncated {kind!r} chunk")
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    if header is None:
        raise DumpError(f"{path}: no IHDR chunk")
    width, height, depth, colour, _, _, interlace = header
    if colour not in CHANNELS or depth not in (8, 16) or interlace != 0:
        raise DumpError(f"{path}: unsupported PNG (bit depth {depth}, colour "
                        f"type {colour}, interlace {interlace})")
    channels = CHANNELS[colour]
    bpp = channels * depth // 8
    try:
        data = zlib.decompress(b"".join(idat))
    except zlib.error as error:
        raise DumpError(f"{path}: corrupt image data ({error})") from error
    raw = _unfilter(data, height, width * bpp, bpp, path)
    if depth == 8:
        return width, height, channels, array.array("B", raw)
    samples = array.array("H", bytes(raw))
    if sys.byteorder == "little":  # PNG stores 16-bit samples big-endian
        samples.byteswap()
    return width, height, channels, samples


def _read_jpeg(path):
    try:
        from PIL import Image
    except ImportError as error:
        raise DumpError(f"{path}: JPEG frames need Pillow (pip install "
                        f"pillow), or dump with --dump-format png") from error
    with Image.open(path) as image:
        rgb = image.convert("RGB")
        return rgb.width, rgb.height, 3, array.array("B", rgb.tobytes())


def read_image(path):
    """(width, height, channels, samples) of a dumped PNG or JPEG."""
    if path.lower().endswith((".jpg", ".jpeg")):
        return _read_jpeg(path)
    return read_png(path)


def _as_image(width, height, channels, samples, np):
    if np is not None:
        dtype = np.uint8 if samples.typecode == "B" else np.uint16
        image = np.frombuffer(samples.tobytes(), dtype=dtype)
        shape = (height, width) if channels == 1 else (height, width, channels)
        return image.reshape(shape).copy()
    if channels == 1:
        return [list(samples[y * width:(y + 1) * width]) for y in range(height)]
    row = width * channels
    return [[list(samples[y * row + x * channels:y * row + (x + 1) * channels])
             for x in range(width)] for y in range(height)]


def _numpy(use_numpy):
    if use_numpy is False:
        return None
    try:
        import numpy
        return numpy
    except ImportError:
        if use_numpy:
            raise
        return None


def list_episodes(root, split):
    """The complete episode folders of <root>/<split>, by episode id."""
    folder = os.path.join(root, split)
    ids = [name for name in os.listdir(folder)
           if name.isdigit() and
           os.path.exists(os.path.join(folder, name, "episode.json"))]
    return [os.path.join(folder, name) for name in sorted(ids, key=int)]


def load_episode(folder, use_numpy=None, images=True):
    """Loads one episode folder.

    Returns a dict: "episode" (episode.json), "steps" (the records of
    steps.jsonl, one per frame), "actions" (action codes of frames 0..T-1),
    and with `images` "rgb" and "depth_mm" (per frame; numpy arrays
    [T, H, W, 3] uint8 and [T, H, W] uint16 when numpy is used, nested lists
    otherwise). `use_numpy`: None uses numpy when importable.
    """
    np = _numpy(use_numpy)
    with open(os.path.join(folder, "episode.json")) as f:
        episode = json.load(f)
    with open(os.path.join(folder, "steps.jsonl")) as f:
        steps = [json.loads(line) for line in f if line.strip()]
    if len(steps) != episode["num_frames"]:
        raise DumpError(f"{folder}: {len(steps)} steps for "
                        f"num_frames {episode['num_frames']}")
    out = {"episode": episode, "steps": steps,
           "actions": [s["action"] for s in steps if s["action"] is not None]}
    if not images:
        return out
    for key, field in (("rgb", "rgb"), ("depth_mm", "depth")):
        frames = []
        for step in steps:
            if step[field] is None:
                continue
            frames.append(_as_image(*read_image(os.path.join(folder,
                                                             step[field])),
                                    np))
        out[key] = np.stack(frames) if np is not None and frames else frames
    return out


def depth_metres(depth_mm, np=None):
    """Depth in metres from millimetres; 0 (no valid depth) becomes NaN."""
    np = np or _numpy(None)
    if np is not None and hasattr(depth_mm, "dtype"):
        metres = depth_mm.astype(np.float32) / 1000.0
        metres[depth_mm == 0] = np.nan
        return metres
    nan = float("nan")
    if isinstance(depth_mm, list):
        return [depth_metres(d, np) for d in depth_mm]
    return depth_mm / 1000.0 if depth_mm else nan


def _total(values):
    if hasattr(values, "sum"):
        return int(values.astype("int64").sum())
    if isinstance(values, list):
        return sum(_total(v) for v in values)
    return int(values)


def _shape(values):
    if hasattr(values, "shape"):
        return list(values.shape)
    shape = []
    while isinstance(values, list):
        shape.append(len(values))
        values = values[0] if values else None
    return shape


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", help="an episode folder, DIR/<split>/<id>")
    parser.add_argument("--no-numpy", action="store_true",
                        help="return nested lists even when numpy is present")
    args = parser.parse_args()
    try:
        ep = load_episode(args.folder, use_numpy=False if args.no_numpy
                          else None)
    except (DumpError, OSError, ValueError, KeyError) as error:
        print(f"read_observation_dump.py: error: {error}", file=sys.stderr)
        return 1
    depth = ep["depth_mm"]
    summary = {
        "episode_id": ep["episode"]["episode_id"],
        "instruction": ep["episode"]["instruction"]["text"],
        "num_frames": len(ep["steps"]),
        "actions": ep["actions"],
        "numpy": not args.no_numpy and _numpy(None) is not None,
        "rgb_shape": _shape(ep["rgb"]),
        "depth_shape": _shape(depth),
        "rgb_sum": _total(ep["rgb"]),
        "depth_sum_mm": _total(depth),
    }
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
