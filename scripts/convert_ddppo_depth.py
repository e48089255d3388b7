#!/usr/bin/env python3
"""Converts a DD-PPO point-goal checkpoint's depth encoder into the
TorchScript tensor archive that vlnce-cpp reads as `model.depth_weights`.

VLN-CE's depth encoder is the visual encoder of a DD-PPO agent trained for
PointGoal navigation on depth (habitat_baselines' ResNetEncoder: a GroupNorm
ResNet-50 with base width 32 plus a compression conv), loaded from
data/ddppo-models/gibson-2plus-resnet50.pth. Its tensors live in the
checkpoint's "state_dict" under "actor_critic.net.visual_encoder."; the C++
encoder (src/models/ResNet.h, DdppoResNetEncoder) uses the names that follow
that prefix ("backbone.conv1.0.weight", "compression.1.bias", ...), so the
conversion keeps exactly those tensors with the prefix removed. The output is
a TorchScript archive (a tree of empty modules holding the tensors as
buffers) that C++ opens with torch::jit::load, without Python.

On a machine with internet access:

    wget https://dl.fbaipublicfiles.com/habitat/data/baselines/v1/ddppo/ddppo-models.zip
    unzip ddppo-models.zip -d data/ddppo-models
    python3 scripts/convert_ddppo_depth.py \
        data/ddppo-models/gibson-2plus-resnet50.pth \
        --out data/weights/depth_ddppo_resnet50.pt

then set `model.depth_weights: data/weights/depth_ddppo_resnet50.pt` (and
`model.depth_encoder: resnet50`, 256x256 depth for the [128, 4, 4] output).
The checkpoint also pickles a habitat config object; when habitat is not
installed that object is replaced by a placeholder, since only the tensors
are needed.
"""
import argparse
import pickle
import sys

import torch

from weight_archive import tensor_archive

PREFIX = "actor_critic.net.visual_encoder."


class _Placeholder(dict):
    """Stands in for classes of packages that are not installed (habitat's
    Config, a dict subclass, pickled next to the weights)."""

    def __setstate__(self, state):
        if isinstance(state, dict):
            self.update(state)


class _Unpickler(pickle.Unpickler):
    def find_class(self, module, name):
        try:
            return super().find_class(module, name)
        except (ImportError, AttributeError):
            return _Placeholder


def load_checkpoint(path):
    """torch.load with unknown classes replaced by _Placeholder. torch 1.13
    ignores a custom pickle_module (it resets it to `pickle`), so the
    Unpickler of the pickle module itself is swapped for the duration."""
    original = pickle.Unpickler
    pickle.Unpickler = _Unpickler
    try:
        return torch.load(path, map_location="cpu", weights_only=False)
    finally:
        pickle.Unpickler = original


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("checkpoint", help="DD-PPO checkpoint (.pth)")
    parser.add_argument("--out", required=True, help="output archive (.pt)")
    args = parser.parse_args()

    checkpoint = load_checkpoint(args.checkpoint)
    if "state_dict" not in checkpoint:
        sys.exit(f"convert_ddppo_depth: {args.checkpoint} has no 'state_dict'"
                 f" (keys: {sorted(checkpoint)})")
    tensors = {k[len(PREFIX):]: v for k, v in checkpoint["state_dict"].items()
               if k.startswith(PREFIX)}
    if not tensors:
        sys.exit(f"convert_ddppo_depth: no tensor of {args.checkpoint} starts "
                 f"with '{PREFIX}'")
    if any(k.startswith("running_mean_and_var.") for k in tensors):
        sys.exit(f"convert_ddppo_depth: {args.checkpoint} normalises its "
                 "inputs (running_mean_and_var, an RGB agent?); VLN-CE's "
                 "depth encoder is a depth-only agent without it")
    missing = [k for k in ("backbone.conv1.0.weight", "compression.0.weight")
               if k not in tensors]
    if missing:
        sys.exit(f"convert_ddppo_depth: {args.checkpoint} lacks {missing}; "
                 "not a habitat_baselines ResNetEncoder")
    conv1 = tensors["backbone.conv1.0.weight"]
    if conv1.shape[1] != 1:
        sys.exit(f"convert_ddppo_depth: the encoder takes {conv1.shape[1]} "
                 "input channels, expected 1 (depth only)")
    tensor_archive(tensors).save(args.out)
    print(f"wrote {args.out}: {len(tensors)} tensors, base width "
          f"{conv1.shape[0]}, compression to "
          f"{tensors['compression.0.weight'].shape[0]} channels")


if __name__ == "__main__":
    main()
