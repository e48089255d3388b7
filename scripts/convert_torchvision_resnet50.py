#!/usr/bin/env python3
"""Converts torchvision's ImageNet ResNet weights into the TorchScript tensor
archive that vlnce-cpp reads as `model.rgb_weights`.

VLN-CE's RGB encoder is torchvision's ImageNet ResNet-50
(`models.resnet50(pretrained=True)`, i.e. the IMAGENET1K_V1 weights). The
C++ encoder (src/models/ResNet.h, TorchVisionResNet) uses torchvision's
parameter names, so the conversion only drops the classifier (`fc.*`) and
stores every remaining parameter and BatchNorm buffer under its
state_dict name ("conv1.weight", "layer1.0.bn1.running_mean", ...). The
output is a TorchScript archive (a tree of empty modules holding the
tensors as buffers) that C++ opens with torch::jit::load, without Python.

On a machine with internet access, either

    # torchvision downloads the weights itself
    python3 scripts/convert_torchvision_resnet50.py --out data/weights/rgb_resnet50.pt

or, with the weight file downloaded by hand from torchvision's model zoo
(https://download.pytorch.org/models/resnet50-0676ba61.pth, no torchvision
needed):

    python3 scripts/convert_torchvision_resnet50.py \
        --state-dict resnet50-0676ba61.pth --out data/weights/rgb_resnet50.pt

then set `model.rgb_weights: data/weights/rgb_resnet50.pt`. `--arch resnet18`
converts ResNet-18 the same way (model.rgb_encoder: resnet18).
"""
import argparse
import sys

import torch

from weight_archive import tensor_archive

# torchvision's state_dict sizes without fc.*: entries and parameters
EXPECTED = {"resnet50": (318, 23508032), "resnet18": (120, 11176512)}


def load_state_dict(args):
    if args.state_dict:
        state = torch.load(args.state_dict, map_location="cpu")
        return state.get("state_dict", state)
    try:
        import torchvision
    except ImportError:
        sys.exit("convert_torchvision_resnet50: torchvision is not installed; "
                 "download the .pth file and pass --state-dict")
    builder = getattr(torchvision.models, args.arch)
    try:
        model = builder(weights="IMAGENET1K_V1")
    except TypeError:  # torchvision < 0.13
        model = builder(pretrained=True)
    return model.state_dict()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--arch", choices=sorted(EXPECTED), default="resnet50")
    parser.add_argument("--state-dict",
                        help="torchvision .pth file (skips torchvision)")
    parser.add_argument("--out", required=True, help="output archive (.pt)")
    args = parser.parse_args()

    state = load_state_dict(args)
    tensors = {k: v for k, v in state.items() if not k.startswith("fc.")}
    entries, params = EXPECTED[args.arch]
    counted = sum(v.numel() for k, v in tensors.items()
                  if not k.endswith(("running_mean", "running_var",
                                     "num_batches_tracked")))
    if len(tensors) != entries or counted != params:
        sys.exit(f"convert_torchvision_resnet50: {args.state_dict or 'weights'}"
                 f" has {len(tensors)} tensors / {counted} parameters without "
                 f"fc, expected {entries} / {params} for torchvision "
                 f"{args.arch}")
    tensor_archive(tensors).save(args.out)
    print(f"wrote {args.out}: {len(tensors)} tensors of torchvision "
          f"{args.arch} (fc dropped)")


if __name__ == "__main__":
    main()
