#!/usr/bin/env python3
"""Converts a VLN-CE policy checkpoint (CMAPolicy or Seq2SeqPolicy) into the
files that vlnce-cpp's `eval --checkpoint` reads: a checkpoint, the RGB and
depth encoder weights and a run config.

VLN-CE (Krantz et al. 2020, https://github.com/jacobkrantz/VLN-CE) saves
`torch.save({"state_dict": policy.state_dict(), "config": config})`, the
config being a habitat/yacs Config. The file is read by habitat_pickle.py,
which refuses any pickled global other than tensors, containers and that
config. Two key layouts are read:

  2020  the public release (habitat-api 0.1.5; the released CMA_PM_DA_Aug and
        Seq2Seq_DA were trained with it): the RGB ResNet's torchvision names
        under net.rgb_encoder.cnn.conv1..., DD-PPO's critic head critic.fc.*,
        Seq2Seq's RGB projection net.rgb_encoder.fc.*;
  2021  the code since the RxR merge (habitat-lab 0.1.7): the ResNet as a
        Sequential (net.rgb_encoder.cnn.0 conv1, .1 bn1, .4-.7 layer1-4),
        no critic, net.rgb_encoder.fc.1.* for Seq2Seq.

Every tensor of the policy is accounted for: the RGB ResNet goes to
rgb_encoder.pt (torchvision names, as convert_torchvision_resnet50.py
writes), the depth encoder's net.depth_encoder.visual_encoder.* to
depth_encoder.pt (as convert_ddppo_depth.py writes), the rest, renamed, to
the policy tensors of ckpt.0.pth; DD-PPO's critic, Seq2Seq's ImageNet
classifier (2020), the constant attention scale and, without the progress
monitor, its unused head are dropped. Unknown or missing keys, wrong shapes
and settings the C++ models cannot represent (GRU instruction encoders, LSTM
state encoders, ablations by zeroing, observation transforms, ...) are
errors naming the file, the key and the value.

VLN-CE feeds RGB as pixels / 255 (MODEL.normalize_rgb: False, its only
setting before 2021), so the run config sets model.normalize_rgb: false.
Seq2Seq averages the whole ResNet map; ours averages its 4x4 adaptive
pooling, which is the same function only when the map's sides divide into
4 cells evenly (1, 2, 4, 8, ... pixels). At 224x224 (a 7x7 map) it is not,
and the conversion needs --accept-seq2seq-rgb-pooling. CMA pools to 4x4 as
ours does and is exact at any size.

On a machine with the checkpoint (docs/paper_scale.md, "Evaluating VLN-CE's
released checkpoints"):

    python3 scripts/convert_vlnce_checkpoint.py \\
        data/checkpoints/CMA_PM_DA_Aug.pth --out-dir data/vlnce/cma_pm_da_aug \\
        --base configs/paper/base.yaml
    build/bin/eval --config data/vlnce/cma_pm_da_aug/config.yaml \\
        --checkpoint data/vlnce/cma_pm_da_aug/ckpt.0.pth --split val_unseen

Paths in the written config are as given on the command line (relative to
the directory the binaries run in, the repository root).
"""
import argparse
import json
import os
import sys

import torch

from habitat_pickle import CheckpointError, load_checkpoint, to_plain
from weight_archive import tensor_archive

# VLN-CE's fixed sizes (cma_policy.py, seq2seq_policy.py, resnet_encoders.py)
PREV_ACTION_DIM = 32
SPATIAL_DIM = 64
NUM_ACTIONS = 4
RGB_POOL = 4

RGB_ARCHS = {"TorchVisionResNet50": "resnet50",
             "TorchVisionResNet18": "resnet18"}
DEPTH_BACKBONES = ("resnet50", "resnet18")
RESNET_BLOCKS = {"resnet18": (2, 2, 2, 2), "resnet50": (3, 4, 6, 3)}

CHECKPOINT_FORMAT = "vlnce-cpp checkpoint"
CHECKPOINT_VERSION = 1


class ConversionError(Exception):
    """A checkpoint that cannot be converted; the message names the file."""


# ---------------------------------------------------------------------------
# expected tensor shapes of the encoders


def torchvision_resnet_shapes(arch):
    """torchvision ResNet-18/50 state_dict shapes without fc."""
    bottleneck = arch == "resnet50"
    expansion = 4 if bottleneck else 1
    shapes = {}

    def batchnorm(prefix, channels):
        for name in ("weight", "bias", "running_mean", "running_var"):
            shapes[f"{prefix}.{name}"] = (channels,)
        shapes[f"{prefix}.num_batches_tracked"] = ()

    shapes["conv1.weight"] = (64, 3, 7, 7)
    batchnorm("bn1", 64)
    inplanes = 64
    for stage, (planes, blocks) in enumerate(
            zip((64, 128, 256, 512), RESNET_BLOCKS[arch])):
        for block in range(blocks):
            p = f"layer{stage + 1}.{block}"
            stride = 2 if stage > 0 and block == 0 else 1
            if bottleneck:
                shapes[f"{p}.conv1.weight"] = (planes, inplanes, 1, 1)
                shapes[f"{p}.conv2.weight"] = (planes, planes, 3, 3)
                shapes[f"{p}.conv3.weight"] = (planes * 4, planes, 1, 1)
                batchnorm(f"{p}.bn1", planes)
                batchnorm(f"{p}.bn2", planes)
                batchnorm(f"{p}.bn3", planes * 4)
            else:
                shapes[f"{p}.conv1.weight"] = (planes, inplanes, 3, 3)
                shapes[f"{p}.conv2.weight"] = (planes, planes, 3, 3)
                batchnorm(f"{p}.bn1", planes)
                batchnorm(f"{p}.bn2", planes)
            if stride != 1 or inplanes != planes * expansion:
                shapes[f"{p}.downsample.0.weight"] = (planes * expansion,
                                                      inplanes, 1, 1)
                batchnorm(f"{p}.downsample.1", planes * expansion)
            inplanes = planes * expansion
    return shapes, inplanes


def ddppo_encoder_shapes(arch, base, height):
    """habitat_baselines ResNetEncoder (depth only, GroupNorm) shapes, and
    the encoder's output shape [C, h, w] for `height` x `height` images
    (VLN-CE's square depth)."""
    bottleneck = arch == "resnet50"
    expansion = 4 if bottleneck else 1
    shapes = {}

    def groupnorm(prefix, channels):
        shapes[f"{prefix}.weight"] = (channels,)
        shapes[f"{prefix}.bias"] = (channels,)

    shapes["backbone.conv1.0.weight"] = (base, 1, 7, 7)
    groupnorm("backbone.conv1.1", base)
    inplanes = base
    for stage, blocks in enumerate(RESNET_BLOCKS[arch]):
        planes = base * 2**stage
        for block in range(blocks):
            p = f"backbone.layer{stage + 1}.{block}"
            stride = 2 if stage > 0 and block == 0 else 1
            if bottleneck:
                shapes[f"{p}.convs.0.weight"] = (planes, inplanes, 1, 1)
                groupnorm(f"{p}.convs.1", planes)
                shapes[f"{p}.convs.3.weight"] = (planes, planes, 3, 3)
                groupnorm(f"{p}.convs.4", planes)
                shapes[f"{p}.convs.6.weight"] = (planes * 4, planes, 1, 1)
                groupnorm(f"{p}.convs.7", planes * 4)
            else:
                shapes[f"{p}.convs.0.weight"] = (planes, inplanes, 3, 3)
                groupnorm(f"{p}.convs.1", planes)
                shapes[f"{p}.convs.3.weight"] = (planes, planes, 3, 3)
                groupnorm(f"{p}.convs.4", planes)
            if stride != 1 or inplanes != planes * expansion:
                shapes[f"{p}.downsample.0.weight"] = (planes * expansion,
                                                      inplanes, 1, 1)
                groupnorm(f"{p}.downsample.1", planes * expansion)
            inplanes = planes * expansion
    final_spatial = (height // 2) // 32
    channels = round(2048 / final_spatial**2)
    shapes["compression.0.weight"] = (channels, inplanes, 3, 3)
    groupnorm("compression.1", channels)
    side = ddppo_spatial(height)
    return shapes, (channels, side, side)


def conv_out(size, kernel, stride, padding):
    return (size + 2 * padding - kernel) // stride + 1


def resnet_spatial(size):
    """Side of a ResNet's output map (7x7/2 stem, 3x3/2 pool, three /2)."""
    size = conv_out(size, 7, 2, 3)
    size = conv_out(size, 3, 2, 1)
    for _ in range(3):
        size = conv_out(size, 3, 2, 1)
    return size


def ddppo_spatial(size):
    """Side of DD-PPO's ResNetEncoder output (2x average pool first)."""
    return resnet_spatial(size // 2)


def pooled_mean_is_mean(side, cells=RGB_POOL):
    """True when the mean of adaptive_avg_pool(side -> cells) equals the
    mean of the map, i.e. every pixel carries the same total weight."""
    weights = [0.0] * side
    for i in range(cells):
        start = (i * side) // cells
        end = -((-(i + 1) * side) // cells)
        for j in range(start, end):
            weights[j] += 1.0 / (end - start)
    return all(abs(w - cells / side) < 1e-9 for w in weights)


# ---------------------------------------------------------------------------
# the config


class Settings:
    """Reads dotted keys of the checkpoint's config, with VLN-CE's defaults
    for keys that an older config does not have."""

    def __init__(self, config, path):
        self.config = config
        self.path = path

    def get(self, key, default=None):
        """The value at a dotted key, `default` when a part is missing."""
        node = self.config
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                return default
            node = node[part]
        return node

    def require(self, key, allowed, default, why):
        """get(key, default), which must be one of `allowed`; else an error
        naming the setting, its value and `why`."""
        value = self.get(key, default)
        if value not in allowed:
            raise ConversionError(
                f"{self.path}: unsupported setting {key} = {value!r} "
                f"({why}; supported: "
                f"{', '.join(repr(a) for a in allowed)})")
        return value


def read_settings(settings, state):
    """The model and environment settings of the checkpoint, checked."""
    s = settings
    path = s.path
    if not isinstance(s.get("MODEL"), dict):
        raise ConversionError(f"{path}: its config has no MODEL section")
    out = {}

    # which policy: MODEL.policy_name (2021) or MODEL.CMA.use (2020)
    name = s.get("MODEL.policy_name")
    if name is not None:
        s.require("MODEL.policy_name", ("CMAPolicy", "Seq2SeqPolicy"), None,
                  "only VLN-CE's CMA and Seq2Seq policies are converted")
        cma = name == "CMAPolicy"
    else:
        cma = bool(s.get("MODEL.CMA.use", False))
    has_cma_keys = "net.state_q.weight" in state
    if cma != has_cma_keys:
        raise ConversionError(
            f"{path}: the config names a {'CMA' if cma else 'Seq2Seq'} "
            f"policy but the state_dict {'has' if has_cma_keys else 'lacks'}"
            " net.state_q.weight (a CMA tensor)")
    out["policy"] = "cma" if cma else "seq2seq"
    # our keys without a VLN-CE counterpart: evaluation of frozen encoders
    # with every input, VLN-CE's fixed embedding widths
    out.update({"rgb_trainable": False, "rgb_batch_statistics": False,
                "depth_trainable": False, "no_rgb": False, "no_depth": False,
                "no_instruction": False,
                "prev_action_embedding_dim": PREV_ACTION_DIM,
                "spatial_embedding_dim": SPATIAL_DIM})

    # settings the C++ models do not have
    for key in ("MODEL.ablate_rgb", "MODEL.ablate_depth",
                "MODEL.ablate_instruction"):
        s.require(key, (False,), False,
                  "VLN-CE ablates by zeroing the input; our ablations remove "
                  "it from the network, a different function")
    s.require("MODEL.CMA.rcm_state_encoder", (False,), False,
              "the RCM state encoder is not implemented")
    s.require("MODEL.INSTRUCTION_ENCODER.rnn_type", ("LSTM",), "LSTM",
              "our instruction encoder is an LSTM")
    s.require("MODEL.INSTRUCTION_ENCODER.bidirectional", (cma,), False,
              "ours is bidirectional exactly for CMA")
    s.require("MODEL.INSTRUCTION_ENCODER.sensor_uuid", ("instruction",),
              "instruction", "ours reads token ids, not RxR's text features")
    s.require("MODEL.STATE_ENCODER.rnn_type", ("GRU",), "GRU",
              "our state encoders are GRUs")
    rgb_type = s.require("MODEL.RGB_ENCODER.cnn_type", tuple(RGB_ARCHS),
                         "TorchVisionResNet50",
                         "ours are torchvision ResNets for RGB")
    s.require("MODEL.DEPTH_ENCODER.cnn_type", ("VlnResnetDepthEncoder",),
              "VlnResnetDepthEncoder", "ours is DD-PPO's ResNet for depth")
    depth_arch = s.require("MODEL.DEPTH_ENCODER.backbone", DEPTH_BACKBONES,
                           "resnet50", "our DD-PPO ResNets")
    transforms = s.get("RL.POLICY.OBS_TRANSFORMS.ENABLED_TRANSFORMS", [])
    if transforms:
        raise ConversionError(
            f"{path}: unsupported setting "
            f"RL.POLICY.OBS_TRANSFORMS.ENABLED_TRANSFORMS = {transforms!r} "
            "(our evaluation feeds the sensors' images unchanged)")
    out["rgb_encoder"] = RGB_ARCHS[rgb_type]
    out["depth_encoder"] = depth_arch
    out["normalize_rgb"] = bool(s.get("MODEL.normalize_rgb", False))
    out["fine_tune_embeddings"] = bool(
        s.get("MODEL.INSTRUCTION_ENCODER.fine_tune_embeddings", False))
    out["vocab_size"] = int(s.get("MODEL.INSTRUCTION_ENCODER.vocab_size",
                                  2504))
    out["embedding_dim"] = int(
        s.get("MODEL.INSTRUCTION_ENCODER.embedding_size", 50))
    out["instruction_hidden_size"] = int(
        s.get("MODEL.INSTRUCTION_ENCODER.hidden_size", 128))
    out["hidden_size"] = int(s.get("MODEL.STATE_ENCODER.hidden_size", 512))
    out["rgb_projection_size"] = int(s.get("MODEL.RGB_ENCODER.output_size",
                                           256))
    out["depth_projection_size"] = int(
        s.get("MODEL.DEPTH_ENCODER.output_size", 128))
    out["progress_monitor"] = bool(s.get("MODEL.PROGRESS_MONITOR.use", False))
    out["seq2seq_prev_action"] = (not cma) and bool(
        s.get("MODEL.SEQ2SEQ.use_prev_action", False))
    if out["hidden_size"] % 2:
        raise ConversionError(
            f"{path}: MODEL.STATE_ENCODER.hidden_size = {out['hidden_size']}"
            " is odd; CMA's attention keys are half of it")

    # the task the policy was trained on (habitat_extensions/config/
    # vlnce_task.yaml when the checkpoint's config has no TASK_CONFIG)
    sim = "TASK_CONFIG.SIMULATOR."
    env = {
        "rgb_width": int(s.get(sim + "RGB_SENSOR.WIDTH", 224)),
        "rgb_height": int(s.get(sim + "RGB_SENSOR.HEIGHT", 224)),
        "depth_width": int(s.get(sim + "DEPTH_SENSOR.WIDTH", 256)),
        "depth_height": int(s.get(sim + "DEPTH_SENSOR.HEIGHT", 256)),
    }
    optional = {
        "rgb_hfov": (sim + "RGB_SENSOR.HFOV", float),
        "depth_hfov": (sim + "DEPTH_SENSOR.HFOV", float),
        "rgb_position_y": (sim + "RGB_SENSOR.POSITION", None),
        "depth_position_y": (sim + "DEPTH_SENSOR.POSITION", None),
        "min_depth": (sim + "DEPTH_SENSOR.MIN_DEPTH", float),
        "max_depth": (sim + "DEPTH_SENSOR.MAX_DEPTH", float),
        "normalize_depth": (sim + "DEPTH_SENSOR.NORMALIZE_DEPTH", bool),
        "forward_step_size": (sim + "FORWARD_STEP_SIZE", float),
        "turn_angle": (sim + "TURN_ANGLE", float),
        "allow_sliding": (sim + "HABITAT_SIM_V0.ALLOW_SLIDING", bool),
        "max_episode_steps": ("TASK_CONFIG.ENVIRONMENT.MAX_EPISODE_STEPS",
                              int),
        "success_distance": ("TASK_CONFIG.TASK.SUCCESS_DISTANCE", float),
    }
    for field, (key, kind) in optional.items():
        value = s.get(key)
        if value is None:
            continue
        if kind is None:  # a sensor position [x, y, z]: its height
            if not isinstance(value, list) or len(value) != 3:
                raise ConversionError(
                    f"{path}: {key} = {value!r}, expected [x, y, z]")
            if value[0] != 0 or value[2] != 0:
                raise ConversionError(
                    f"{path}: unsupported setting {key} = {value!r} (our "
                    "cameras sit on the agent's axis: x = z = 0)")
            value = float(value[1])
        else:
            value = kind(value)
        env[field] = value
    if env["depth_width"] != env["depth_height"]:
        raise ConversionError(
            f"{path}: unsupported setting {sim}DEPTH_SENSOR WIDTH x HEIGHT = "
            f"{env['depth_width']} x {env['depth_height']} (DD-PPO's "
            "compression is sized for square depth)")
    if env["depth_height"] < 64:
        raise ConversionError(
            f"{path}: unsupported setting {sim}DEPTH_SENSOR.HEIGHT = "
            f"{env['depth_height']} (DD-PPO's ResNet needs at least 64)")
    out.update({k: env[k] for k in ("rgb_width", "rgb_height",
                                    "depth_width", "depth_height")})
    return out, env


# ---------------------------------------------------------------------------
# the tensors


class StateReader:
    """Takes tensors out of a VLN-CE state_dict by name, checking shapes;
    whatever is left at the end is an unknown key."""

    def __init__(self, state, path):
        self.state = dict(state)
        self.path = path
        self.missing = []

    def take(self, key, shape):
        if key not in self.state:
            self.missing.append(f"{key} {list(shape)}")
            return None
        tensor = self.state.pop(key)
        if not isinstance(tensor, torch.Tensor):
            raise ConversionError(
                f"{self.path}: state_dict[{key!r}] is a "
                f"{type(tensor).__name__}, not a tensor")
        if tuple(tensor.shape) != tuple(shape):
            raise ConversionError(
                f"{self.path}: state_dict[{key!r}] has shape "
                f"{list(tensor.shape)}, expected {list(shape)} for this "
                "model's config")
        return tensor

    def take_linear(self, prefix, out_features, in_features, conv1d=False):
        """(weight [out, in], bias [out]) of an nn.Linear, or of a kernel-1
        nn.Conv1d (weight [out, in, 1]) as the same linear map."""
        shape = ((out_features, in_features, 1) if conv1d else
                 (out_features, in_features))
        weight = self.take(prefix + ".weight", shape)
        bias = self.take(prefix + ".bias", (out_features,))
        if conv1d and weight is not None:
            weight = weight[:, :, 0]
        return weight, bias

    def take_rnn(self, prefix, gates, input_size, hidden, bidirectional):
        """An nn.GRU / nn.LSTM's tensors by PyTorch name."""
        tensors = {}
        for suffix in ("", "_reverse") if bidirectional else ("",):
            for name, shape in (("weight_ih_l0", (gates * hidden, input_size)),
                                ("weight_hh_l0", (gates * hidden, hidden)),
                                ("bias_ih_l0", (gates * hidden,)),
                                ("bias_hh_l0", (gates * hidden,))):
                tensors[name + suffix] = self.take(
                    f"{prefix}.{name}{suffix}", shape)
        return tensors

    def finish(self):
        if self.missing:
            raise ConversionError(
                f"{self.path}: the state_dict lacks "
                f"{len(self.missing)} tensor(s) this model's config needs: "
                + ", ".join(self.missing[:20]) +
                (" ..." if len(self.missing) > 20 else ""))
        if self.state:
            keys = sorted(self.state)
            raise ConversionError(
                f"{self.path}: unknown key(s) in the state_dict: "
                + ", ".join(f"{k} {list(self.state[k].shape)}"
                            if isinstance(self.state[k], torch.Tensor) else k
                            for k in keys[:20]) +
                (" ..." if len(keys) > 20 else ""))


def detect_layout(state, path):
    if "net.rgb_encoder.cnn.conv1.weight" in state:
        return "2020"
    if "net.rgb_encoder.cnn.0.weight" in state:
        return "2021"
    raise ConversionError(
        f"{path}: no RGB ResNet in the state_dict (neither "
        "net.rgb_encoder.cnn.conv1.weight, VLN-CE's 2020 layout, nor "
        "net.rgb_encoder.cnn.0.weight, its 2021 layout): not a VLN-CE "
        "CMAPolicy / Seq2SeqPolicy checkpoint")


# 2021: nn.Sequential(*list(resnet.children())[:-2]) (CMA) or [:-1]
# (Seq2Seq, whose AdaptiveAvgPool2d at index 8 has no tensors)
SEQUENTIAL_RESNET = {"0": "conv1", "1": "bn1", "4": "layer1", "5": "layer2",
                     "6": "layer3", "7": "layer4"}


def rgb_resnet_tensors(reader, layout, arch):
    """The RGB ResNet's tensors under torchvision's names, and its width."""
    shapes, channels = torchvision_resnet_shapes(arch)
    tensors = {}
    for name, shape in shapes.items():
        if layout == "2020":
            key = "net.rgb_encoder.cnn." + name
        else:
            head, rest = name.split(".", 1)
            index = {v: k for k, v in SEQUENTIAL_RESNET.items()}[head]
            key = f"net.rgb_encoder.cnn.{index}.{rest}"
        tensors[name] = reader.take(key, shape)
    return tensors, channels


def convert_state(state, model, env, layout, path):
    """(policy tensors under our names, RGB encoder tensors, depth encoder
    tensors, base width of the depth ResNet, notes)."""
    reader = StateReader(state, path)
    cma = model["policy"] == "cma"
    hidden = model["hidden_size"]
    half = hidden // 2
    text = model["instruction_hidden_size"]
    text_out = 2 * text if cma else text
    rgb_out = model["rgb_projection_size"]
    depth_out = model["depth_projection_size"]
    notes = []

    # encoders
    rgb, rgb_channels = rgb_resnet_tensors(reader, layout,
                                           model["rgb_encoder"])
    conv1 = state.get(
        "net.depth_encoder.visual_encoder.backbone.conv1.0.weight")
    if not isinstance(conv1, torch.Tensor) or conv1.dim() != 4:
        raise ConversionError(
            f"{path}: the state_dict has no depth ResNet "
            "(net.depth_encoder.visual_encoder.backbone.conv1.0.weight)")
    base = int(conv1.shape[0])
    if base < 2 or base % 2:
        raise ConversionError(
            f"{path}: state_dict['net.depth_encoder.visual_encoder.backbone."
            f"conv1.0.weight'] has {base} channels; DD-PPO's base width must "
            "be even (GroupNorm groups = base / 2)")
    depth_shapes, depth_feature = ddppo_encoder_shapes(
        model["depth_encoder"], base, model["depth_height"])
    depth = {name: reader.take("net.depth_encoder.visual_encoder." + name,
                               shape)
             for name, shape in depth_shapes.items()}
    depth_c, depth_h, depth_w = depth_feature
    depth_positions = depth_h * depth_w

    # the policy, in our names (src/models/{Seq2Seq,Cma}Policy.h)
    policy = {}

    def put(ours, tensors):
        for suffix, tensor in tensors.items():
            policy[f"{ours}.{suffix}" if suffix else ours] = tensor

    def linear(ours, prefix, out_f, in_f, conv1d=False):
        w, b = reader.take_linear(prefix, out_f, in_f, conv1d)
        put(ours, {"weight": w, "bias": b})

    embedding = reader.take(
        "net.instruction_encoder.embedding_layer.weight",
        (model["vocab_size"], model["embedding_dim"]))
    put("instruction_encoder.embedding.weight", {"": embedding})
    put("instruction_encoder.lstm",
        reader.take_rnn("net.instruction_encoder.encoder_rnn", 4,
                        model["embedding_dim"], text, bidirectional=cma))

    if cma:
        rgb_in = rgb_channels + SPATIAL_DIM
        depth_in = depth_c + SPATIAL_DIM
        put("rgb_spatial_embedding.weight", {"": reader.take(
            "net.rgb_encoder.spatial_embeddings.weight",
            (RGB_POOL * RGB_POOL, SPATIAL_DIM))})
        put("depth_spatial_embedding.weight", {"": reader.take(
            "net.depth_encoder.spatial_embeddings.weight",
            (depth_positions, SPATIAL_DIM))})
        linear("rgb_linear", "net.rgb_linear.2", rgb_out, rgb_in)
        linear("depth_linear", "net.depth_linear.1", depth_out,
               depth_in * depth_positions)
        put("prev_action_embedding.weight", {"": reader.take(
            "net.prev_action_embedding.weight",
            (NUM_ACTIONS + 1, PREV_ACTION_DIM))})
        put("state_encoder.gru", reader.take_rnn(
            "net.state_encoder.rnn", 3, rgb_out + depth_out + PREV_ACTION_DIM,
            hidden, bidirectional=False))
        linear("state_q", "net.state_q", half, hidden)
        linear("text_k", "net.text_k", half, text_out, conv1d=True)
        linear("text_q", "net.text_q", half, text_out)
        linear("rgb_kv", "net.rgb_kv", half + rgb_out, rgb_in, conv1d=True)
        linear("depth_kv", "net.depth_kv", half + depth_out, depth_in,
               conv1d=True)
        scale = reader.take("net._scale", ())
        if scale is not None and abs(float(scale) - half**-0.5) > 1e-6:
            raise ConversionError(
                f"{path}: state_dict['net._scale'] = {float(scale)}, "
                f"expected 1/sqrt({half})")
        linear("second_state_compress", "net.second_state_compress.0", hidden,
               hidden + text_out + rgb_out + depth_out + PREV_ACTION_DIM)
        put("second_state_encoder.gru", reader.take_rnn(
            "net.second_state_encoder.rnn", 3, hidden, hidden,
            bidirectional=False))
    else:
        linear("depth_linear", "net.depth_encoder.visual_fc.1", depth_out,
               depth_c * depth_positions)
        rgb_fc = ("net.rgb_encoder.fc" if layout == "2020" else
                  "net.rgb_encoder.fc.1")
        linear("rgb_linear", rgb_fc, rgb_out, rgb_channels)
        if layout == "2020":
            # the full torchvision ResNet was kept, ImageNet classifier too
            reader.take("net.rgb_encoder.cnn.fc.weight", (1000, rgb_channels))
            reader.take("net.rgb_encoder.cnn.fc.bias", (1000,))
            notes.append("dropped the RGB ResNet's ImageNet classifier "
                         "net.rgb_encoder.cnn.fc (unused by Seq2Seq)")
        gru_in = text + depth_out + rgb_out
        if model["seq2seq_prev_action"]:
            put("prev_action_embedding.weight", {"": reader.take(
                "net.prev_action_embedding.weight",
                (NUM_ACTIONS + 1, PREV_ACTION_DIM))})
            gru_in += PREV_ACTION_DIM
        put("state_encoder.gru", reader.take_rnn(
            "net.state_encoder.rnn", 3, gru_in, hidden, bidirectional=False))

    # heads: VLN-CE always builds the progress monitor
    pm_w, pm_b = reader.take_linear("net.progress_monitor", 1, hidden)
    if model["progress_monitor"]:
        put("progress_monitor", {"weight": pm_w, "bias": pm_b})
    else:
        notes.append("dropped net.progress_monitor (MODEL.PROGRESS_MONITOR."
                     "use is False: VLN-CE builds but never uses it)")
    w, b = reader.take_linear("action_distribution.linear", NUM_ACTIONS,
                              hidden)
    put("action_head", {"weight": w, "bias": b})
    if layout == "2020":
        reader.take_linear("critic.fc", 1, hidden)
        notes.append("dropped habitat's value head critic.fc (unused by "
                     "imitation learning)")
    reader.finish()

    model["depth_resnet_base_planes"] = base
    if base != 32:
        notes.append(f"the depth ResNet's base width is {base} (VLN-CE's "
                     "VlnResnetDepthEncoder uses 32)")
    return policy, rgb, depth, notes


def check_seq2seq_pooling(model, accept, path):
    """Seq2Seq's mean of the whole RGB map against ours over 4x4 cells."""
    if model["policy"] != "seq2seq":
        return None
    sides = (resnet_spatial(model["rgb_height"]),
             resnet_spatial(model["rgb_width"]))
    if all(pooled_mean_is_mean(side) for side in sides):
        return None
    message = (
        f"VLN-CE's Seq2Seq averages the whole {sides[0]}x{sides[1]} RGB "
        f"ResNet map of its {model['rgb_height']}x{model['rgb_width']} "
        "images; ours averages the map's 4x4 adaptive pooling, whose "
        "overlapping cells weight the map's pixels unequally, so the RGB "
        "input of the GRU (and the logits) are close to VLN-CE's but not "
        "equal")
    if not accept:
        raise ConversionError(
            f"{path}: {message}. Pass --accept-seq2seq-rgb-pooling to "
            "convert it anyway")
    return "approximation: " + message


# ---------------------------------------------------------------------------
# outputs


def yaml_scalar(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    return json.dumps(str(value))  # a double-quoted YAML string


def run_config_yaml(model, env, rgb_path, depth_path, source, base):
    """The run config: model (every key but device), the cameras, the
    agent's actions and the task limits the policy was trained with."""
    lines = ["# Converted by scripts/convert_vlnce_checkpoint.py from",
             f"# {source}"]
    if base:
        lines.append(f"_base_: {yaml_scalar(base)}")
    lines.append("model:")
    keys = ("policy", "rgb_encoder", "depth_encoder")
    for key in keys:
        lines.append(f"  {key}: {model[key]}")
    lines.append(f"  rgb_weights: {yaml_scalar(rgb_path)}")
    lines.append(f"  depth_weights: {yaml_scalar(depth_path)}")
    for key in ("normalize_rgb", "rgb_trainable", "rgb_batch_statistics",
                "depth_trainable", "no_rgb", "no_depth", "no_instruction",
                "vocab_size", "embedding_dim", "fine_tune_embeddings",
                "instruction_hidden_size", "hidden_size",
                "prev_action_embedding_dim", "seq2seq_prev_action",
                "rgb_projection_size", "depth_projection_size",
                "spatial_embedding_dim", "progress_monitor",
                "depth_resnet_base_planes", "rgb_height", "rgb_width",
                "depth_height", "depth_width"):
        lines.append(f"  {key}: {yaml_scalar(model[key])}")
    lines.append("sim:")
    rgb = {"width": env["rgb_width"], "height": env["rgb_height"]}
    depth = {"width": env["depth_width"], "height": env["depth_height"]}
    for ours, theirs in (("hfov", "rgb_hfov"), ("position_y",
                                                "rgb_position_y")):
        if theirs in env:
            rgb[ours] = env[theirs]
    for ours, theirs in (("hfov", "depth_hfov"),
                         ("position_y", "depth_position_y"),
                         ("min_depth", "min_depth"),
                         ("max_depth", "max_depth"),
                         ("normalize_depth", "normalize_depth")):
        if theirs in env:
            depth[ours] = env[theirs]
    agent = {k: env[k] for k in ("forward_step_size", "turn_angle",
                                 "allow_sliding") if k in env}
    for section, values in (("rgb", rgb), ("depth", depth), ("agent", agent)):
        if values:
            lines.append(f"  {section}:")
            lines.extend(f"    {k}: {yaml_scalar(v)}" for k, v in
                         values.items())
    task = {k: env[k] for k in ("max_episode_steps", "success_distance")
            if k in env}
    if task:
        lines.append("task:")
        lines.extend(f"  {k}: {yaml_scalar(v)}" for k, v in task.items())
    return "\n".join(lines) + "\n"


def replace_atomically(path, write):
    """write(temporary path), then rename it over `path`."""
    temporary = f"{path}.tmp{os.getpid()}"
    try:
        write(temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)


def checkpoint_module(config_yaml, policy, progress):
    """Our checkpoint (src/train/Checkpoint.cpp, serializeCheckpoint()) as a
    TorchScript module: the C++ torch::serialize archive is one."""

    class Node(torch.nn.Module):
        pass

    class Archive(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.format = CHECKPOINT_FORMAT
            self.version = CHECKPOINT_VERSION
            self.config_yaml = config_yaml
            self.progress = json.dumps(progress)
            self.policy_names = json.dumps([name for name, _ in policy])
            empty = torch.zeros(0, dtype=torch.uint8)
            self.register_buffer("optimizer_state", empty)
            self.register_buffer("rng_state", empty.clone())
            self.policy = Node()
            for i, (_, tensor) in enumerate(policy):
                self.policy.register_buffer(
                    f"t{i}", tensor.detach().to(torch.float32).contiguous())

    return torch.jit.script(Archive())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("checkpoint", help="VLN-CE checkpoint (.pth)")
    parser.add_argument("--out-dir", required=True,
                        help="directory for ckpt.0.pth, rgb_encoder.pt, "
                        "depth_encoder.pt and config.yaml")
    parser.add_argument("--base", help="run config the written config "
                        "includes with _base_ (data, scenes, eval settings), "
                        "e.g. configs/paper/base.yaml")
    parser.add_argument("--accept-seq2seq-rgb-pooling", action="store_true",
                        help="convert a Seq2Seq policy whose RGB pooling "
                        "ours can only approximate (see above)")
    parser.add_argument("--force", action="store_true",
                        help="overwrite files of an earlier conversion")
    args = parser.parse_args()
    try:
        convert(args)
    except (CheckpointError, ConversionError) as error:
        sys.exit(f"convert_vlnce_checkpoint: {error}")


def convert(args):
    path = args.checkpoint
    checkpoint = load_checkpoint(path)
    if not isinstance(checkpoint, dict) or "state_dict" not in checkpoint:
        keys = sorted(checkpoint) if isinstance(checkpoint, dict) else []
        raise ConversionError(
            f"{path}: not a VLN-CE checkpoint: expected a dict with "
            f"'state_dict' and 'config', got {type(checkpoint).__name__} "
            f"{keys}")
    if not isinstance(checkpoint.get("config"), dict):
        raise ConversionError(
            f"{path}: has no habitat config under 'config' (got "
            f"{type(checkpoint.get('config')).__name__}); the model's "
            "settings are read from it")
    state = checkpoint["state_dict"]
    config = to_plain(checkpoint["config"])
    layout = detect_layout(state, path)
    model, env = read_settings(Settings(config, path), state)
    approximation = check_seq2seq_pooling(
        model, args.accept_seq2seq_rgb_pooling, path)
    policy, rgb, depth, notes = convert_state(state, model, env, layout, path)

    # outputs
    out = args.out_dir
    os.makedirs(out, exist_ok=True)
    files = {name: os.path.join(out, name) for name in (
        "ckpt.0.pth", "rgb_encoder.pt", "depth_encoder.pt", "config.yaml")}
    existing = [f for f in files.values() if os.path.exists(f)]
    if existing and not args.force:
        raise ConversionError(
            f"{out}: already holds {', '.join(existing)} (pass --force to "
            "overwrite)")
    base = None
    if args.base:
        base = os.path.relpath(os.path.abspath(args.base),
                               os.path.abspath(out))
    model_only = run_config_yaml(model, env, files["rgb_encoder.pt"],
                                 files["depth_encoder.pt"], path, None)
    progress = {"checkpoint_index": 0, "dagger_iteration": 0, "epoch": 0,
                "updates": 0, "episodes_collected": 0,
                "stage": "converted", "best_spl": -1.0,
                "best_checkpoint": -1,
                "extra": {"source": os.path.abspath(path),
                          "vlnce_layout": layout}}
    replace_atomically(files["rgb_encoder.pt"],
                       lambda f: tensor_archive(rgb).save(f))
    replace_atomically(files["depth_encoder.pt"],
                       lambda f: tensor_archive(depth).save(f))
    replace_atomically(
        files["ckpt.0.pth"],
        lambda f: checkpoint_module(model_only, list(policy.items()),
                                    progress).save(f))

    def write_config(f):
        with open(f, "w", encoding="utf-8") as stream:
            stream.write(run_config_yaml(model, env, files["rgb_encoder.pt"],
                                         files["depth_encoder.pt"], path,
                                         base))

    replace_atomically(files["config.yaml"], write_config)

    print(f"{path}: VLN-CE {layout} layout, {model['policy']} "
          f"(progress monitor {model['progress_monitor']}), RGB "
          f"{model['rgb_encoder']} {model['rgb_height']}x"
          f"{model['rgb_width']}, depth {model['depth_encoder']} "
          f"{model['depth_height']}x{model['depth_width']}")
    for note in notes:
        print("  " + note)
    if approximation:
        print("  " + approximation)
    print(f"wrote {files['ckpt.0.pth']} ({len(policy)} policy tensors), "
          f"{files['rgb_encoder.pt']} ({len(rgb)}), "
          f"{files['depth_encoder.pt']} ({len(depth)}), "
          f"{files['config.yaml']}")


if __name__ == "__main__":
    main()
