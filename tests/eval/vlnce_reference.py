#!/usr/bin/env python3
"""Helper of ConvertVlnceCheckpointTest: VLN-CE's CMAPolicy and
Seq2SeqPolicy rebuilt from torch.nn layers with VLN-CE's module tree, so that
state_dict() has its exact key layout and shapes (the 2020 release and the
2021 code), plus a step-by-step forward transcribing VLN-CE's modules
(vlnce_baselines/models/{cma,seq2seq}_policy.py, encoders/resnet_encoders.py,
encoders/instruction_encoder.py) and what they build on (torchvision's
ResNet, habitat_baselines' DD-PPO ResNetEncoder and RNNStateEncoder,
CategoricalNet), and a stand-in for the habitat Config that VLN-CE pickles
beside the weights. Nothing of VLN-CE, habitat or torchvision is imported;
the weights are random.

    vlnce_reference.py make OUT_DIR [options]
        OUT_DIR/vlnce.pth   the checkpoint: torch.save of state_dict, config
        OUT_DIR/source.pt   every state_dict tensor by its VLN-CE name
        OUT_DIR/io.pt       inputs [T, B, ...] and VLN-CE's logits [T, B, 4]
    vlnce_reference.py make-many DIR 'NAME: options' ...
        make DIR/NAME for each, in one process, without source.pt and io.pt
    vlnce_reference.py from-ours OUT POLICY RGB DEPTH [options]
        a VLN-CE checkpoint holding the tensors of our checkpoint POLICY and
        our encoder files RGB, DEPTH (the names mapped the other way)
"""
import argparse
import ast
import os
import shlex
import sys
import types

import torch
import torch.nn.functional as F
from torch import nn

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                "..", "..", "scripts"))
from weight_archive import tensor_archive  # noqa: E402

# ---------------------------------------------------------------------------
# habitat's Config: a yacs CfgNode (a dict subclass with attributes of its
# own) defined in habitat.config.default; pickled by class path


def _install_config_classes():
    for name in ("habitat", "habitat.config", "habitat.config.default",
                 "yacs", "yacs.config"):
        sys.modules.setdefault(name, types.ModuleType(name))

    class CfgNode(dict):
        def __init__(self, values=None):
            super().__init__()
            self.__immutable__ = True
            self.__deprecated_keys__ = {"SIMULATOR_GPU_ID"}
            self.__renamed_keys__ = {}
            self.__new_allowed__ = False
            for key, value in (values or {}).items():
                self[key] = Config(value) if isinstance(value, dict) else value

    class Config(CfgNode):
        pass

    CfgNode.__module__, CfgNode.__qualname__ = "yacs.config", "CfgNode"
    Config.__module__, Config.__qualname__ = "habitat.config.default", "Config"
    sys.modules["yacs.config"].CfgNode = CfgNode
    sys.modules["habitat.config.default"].Config = Config
    return Config


Config = _install_config_classes()


class Attack:
    """Unpickles as os.system(command)."""

    def __init__(self, command):
        self.command = command

    def __reduce__(self):
        return (os.system, (self.command,))


# ---------------------------------------------------------------------------
# torchvision's ResNet (models/resnet.py): conv1, bn1, relu, maxpool,
# layer1-4, avgpool, fc, in that order of children


class TvBasicBlock(nn.Module):
    expansion = 1

    def __init__(self, inplanes, planes, stride, downsample):
        super().__init__()
        self.conv1 = nn.Conv2d(inplanes, planes, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(planes)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(planes, planes, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(planes)
        self.downsample = downsample

    def forward(self, x):
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        return self.relu(self.bn2(self.conv2(out)) + identity)


class TvBottleneck(nn.Module):
    expansion = 4

    def __init__(self, inplanes, planes, stride, downsample):
        super().__init__()
        self.conv1 = nn.Conv2d(inplanes, planes, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(planes)
        self.conv2 = nn.Conv2d(planes, planes, 3, stride, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(planes)
        self.conv3 = nn.Conv2d(planes, planes * 4, 1, bias=False)
        self.bn3 = nn.BatchNorm2d(planes * 4)
        self.relu = nn.ReLU(inplace=True)
        self.downsample = downsample

    def forward(self, x):
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.relu(self.bn2(self.conv2(out)))
        return self.relu(self.bn3(self.conv3(out)) + identity)


class TvResNet(nn.Module):
    def __init__(self, arch):
        super().__init__()
        block = TvBottleneck if arch == "resnet50" else TvBasicBlock
        counts = (3, 4, 6, 3) if arch == "resnet50" else (2, 2, 2, 2)
        self.inplanes = 64
        self.conv1 = nn.Conv2d(3, 64, 7, 2, 3, bias=False)
        self.bn1 = nn.BatchNorm2d(64)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(3, 2, 1)
        self.layer1 = self._layer(block, 64, counts[0], 1)
        self.layer2 = self._layer(block, 128, counts[1], 2)
        self.layer3 = self._layer(block, 256, counts[2], 2)
        self.layer4 = self._layer(block, 512, counts[3], 2)
        self.avgpool = nn.AdaptiveAvgPool2d((1, 1))
        self.fc = nn.Linear(512 * block.expansion, 1000)
        self.out_channels = 512 * block.expansion

    def _layer(self, block, planes, count, stride):
        downsample = None
        if stride != 1 or self.inplanes != planes * block.expansion:
            downsample = nn.Sequential(
                nn.Conv2d(self.inplanes, planes * block.expansion, 1, stride,
                          bias=False),
                nn.BatchNorm2d(planes * block.expansion))
        layers = [block(self.inplanes, planes, stride, downsample)]
        self.inplanes = planes * block.expansion
        layers += [block(self.inplanes, planes, 1, None)
                   for _ in range(1, count)]
        return nn.Sequential(*layers)


class SpatialAvgPool(nn.Module):
    def forward(self, x):
        return F.adaptive_avg_pool2d(x, (4, 4))


# ---------------------------------------------------------------------------
# habitat_baselines' DD-PPO ResNet (rl/ddppo/policy/resnet.py) and
# ResNetEncoder (resnet_policy.py), depth only, no input normalisation


class DdBasicBlock(nn.Module):
    expansion = 1

    def __init__(self, inplanes, planes, ngroups, stride, downsample):
        super().__init__()
        self.convs = nn.Sequential(
            nn.Conv2d(inplanes, planes, 3, stride, 1, bias=False),
            nn.GroupNorm(ngroups, planes), nn.ReLU(True),
            nn.Conv2d(planes, planes, 3, 1, 1, bias=False),
            nn.GroupNorm(ngroups, planes))
        self.downsample = downsample
        self.relu = nn.ReLU(True)

    def forward(self, x):
        residual = x if self.downsample is None else self.downsample(x)
        return self.relu(self.convs(x) + residual)


class DdBottleneck(DdBasicBlock):
    expansion = 4

    def __init__(self, inplanes, planes, ngroups, stride, downsample):
        nn.Module.__init__(self)
        self.convs = nn.Sequential(
            nn.Conv2d(inplanes, planes, 1, bias=False),
            nn.GroupNorm(ngroups, planes), nn.ReLU(True),
            nn.Conv2d(planes, planes, 3, stride, 1, bias=False),
            nn.GroupNorm(ngroups, planes), nn.ReLU(True),
            nn.Conv2d(planes, planes * 4, 1, bias=False),
            nn.GroupNorm(ngroups, planes * 4))
        self.downsample = downsample
        self.relu = nn.ReLU(True)


class DdResNet(nn.Module):
    def __init__(self, arch, base, ngroups):
        super().__init__()
        block = DdBottleneck if arch == "resnet50" else DdBasicBlock
        counts = (3, 4, 6, 3) if arch == "resnet50" else (2, 2, 2, 2)
        self.conv1 = nn.Sequential(nn.Conv2d(1, base, 7, 2, 3, bias=False),
                                   nn.GroupNorm(ngroups, base), nn.ReLU(True))
        self.maxpool = nn.MaxPool2d(3, 2, 1)
        self.inplanes = base
        self.layer1 = self._layer(block, ngroups, base, counts[0], 1)
        self.layer2 = self._layer(block, ngroups, base * 2, counts[1], 2)
        self.layer3 = self._layer(block, ngroups, base * 4, counts[2], 2)
        self.layer4 = self._layer(block, ngroups, base * 8, counts[3], 2)
        self.final_channels = self.inplanes

    def _layer(self, block, ngroups, planes, count, stride):
        downsample = None
        if stride != 1 or self.inplanes != planes * block.expansion:
            downsample = nn.Sequential(
                nn.Conv2d(self.inplanes, planes * block.expansion, 1, stride,
                          bias=False),
                nn.GroupNorm(ngroups, planes * block.expansion))
        layers = [block(self.inplanes, planes, ngroups, stride, downsample)]
        self.inplanes = planes * block.expansion
        layers += [block(self.inplanes, planes, ngroups, 1, None)
                   for _ in range(1, count)]
        return nn.Sequential(*layers)

    def forward(self, x):
        x = self.maxpool(self.conv1(x))
        return self.layer4(self.layer3(self.layer2(self.layer1(x))))


class ResNetEncoder(nn.Module):
    def __init__(self, arch, base, height):
        super().__init__()
        self.running_mean_and_var = nn.Sequential()
        self.backbone = DdResNet(arch, base, base // 2)
        final_spatial = (height // 2) // 32
        channels = round(2048 / final_spatial**2)
        self.compression = nn.Sequential(
            nn.Conv2d(self.backbone.final_channels, channels, 3, padding=1,
                      bias=False),
            nn.GroupNorm(1, channels), nn.ReLU(True))
        self.output_shape = (channels, final_spatial, final_spatial)

    def forward(self, depth):
        x = F.avg_pool2d(depth.permute(0, 3, 1, 2), 2)
        x = self.running_mean_and_var(x)
        return self.compression(self.backbone(x))


# ---------------------------------------------------------------------------
# VLN-CE's encoders (resnet_encoders.py, instruction_encoder.py)


class VlnResnetDepthEncoder(nn.Module):
    def __init__(self, arch, base, height, output_size, spatial_output):
        super().__init__()
        self.visual_encoder = ResNetEncoder(arch, base, height)
        shape = self.visual_encoder.output_shape
        self.spatial_output = spatial_output
        if spatial_output:
            self.spatial_embeddings = nn.Embedding(shape[1] * shape[2], 64)
            self.output_shape = (shape[0] + 64, shape[1], shape[2])
        else:
            self.visual_fc = nn.Sequential(
                nn.Flatten(), nn.Linear(shape[0] * shape[1] * shape[2],
                                        output_size), nn.ReLU(True))

    def forward(self, depth):
        x = self.visual_encoder(depth)
        if not self.spatial_output:
            return self.visual_fc(x)
        b, _, h, w = x.size()
        positions = self.spatial_embeddings(torch.arange(
            self.spatial_embeddings.num_embeddings))
        positions = positions.view(1, -1, h, w).expand(b, -1, h, w)
        return torch.cat([x, positions], dim=1)


def rgb_to_input(rgb, normalize):
    x = rgb.permute(0, 3, 1, 2).contiguous().float() / 255.0
    if normalize:
        mean = torch.tensor([0.485, 0.456, 0.406])[None, :, None, None]
        std = torch.tensor([0.229, 0.224, 0.225])[None, :, None, None]
        x = x.sub(mean).div(std)
    return x


class TorchVisionResNet2021(nn.Module):
    """resnet_encoders.TorchVisionResNet since the RxR merge."""

    def __init__(self, arch, output_size, normalize, spatial_output):
        super().__init__()
        self.normalize = normalize
        self.spatial_output = spatial_output
        resnet = TvResNet(arch)
        self.resnet_layer_size = resnet.out_channels
        self.cnn = nn.Sequential(*list(resnet.children())[:-1])
        if spatial_output:
            self.cnn = nn.Sequential(*list(self.cnn.children())[:-1])
            self.cnn.avgpool = SpatialAvgPool()
            self.spatial_embeddings = nn.Embedding(16, 64)
        else:
            self.fc = nn.Sequential(
                nn.Flatten(), nn.Linear(self.resnet_layer_size, output_size),
                nn.ReLU())

    def forward(self, rgb):
        x = self.cnn(rgb_to_input(rgb, self.normalize))
        if not self.spatial_output:
            return self.fc(x)
        return append_positions(x, self.spatial_embeddings)


class TorchVisionResNet2020(nn.Module):
    """resnet_encoders.TorchVisionResNet50 of the 2020 release."""

    def __init__(self, output_size, spatial_output):
        super().__init__()
        self.spatial_output = spatial_output
        self.cnn = TvResNet("resnet50")
        self.resnet_layer_size = 2048
        if spatial_output:
            self.cnn.avgpool = SpatialAvgPool()
            self.cnn.fc = nn.Sequential()
            self.spatial_embeddings = nn.Embedding(16, 64)
        else:
            self.fc = nn.Linear(2048, output_size)
            self.activation = nn.ReLU()

    def forward(self, rgb):
        # the output of cnn.avgpool, which VLN-CE reads with a forward hook
        c = self.cnn
        x = c.maxpool(c.relu(c.bn1(c.conv1(rgb_to_input(rgb, False)))))
        x = c.avgpool(c.layer4(c.layer3(c.layer2(c.layer1(x)))))
        if not self.spatial_output:
            return self.activation(self.fc(torch.flatten(x, 1)))
        return append_positions(x, self.spatial_embeddings)


def append_positions(x, embedding):
    b, _, h, w = x.size()
    positions = embedding(torch.arange(embedding.num_embeddings))
    positions = positions.view(1, -1, h, w).expand(b, -1, h, w)
    return torch.cat([x, positions], dim=1)


class InstructionEncoder(nn.Module):
    def __init__(self, vocab, embedding, hidden, bidirectional,
                 final_state_only):
        super().__init__()
        self.final_state_only = final_state_only
        self.encoder_rnn = nn.LSTM(embedding, hidden,
                                   bidirectional=bidirectional)
        # nn.Embedding.from_pretrained(GloVe rows): no padding_idx
        table = torch.randn(vocab, embedding)
        table[0] = 0
        self.embedding_layer = nn.Embedding.from_pretrained(table)

    def forward(self, tokens):
        lengths = (tokens != 0).long().sum(dim=1)
        packed = nn.utils.rnn.pack_padded_sequence(
            self.embedding_layer(tokens), lengths, batch_first=True,
            enforce_sorted=False)
        output, (h, _) = self.encoder_rnn(packed)
        if self.final_state_only:
            return h.squeeze(0)
        return nn.utils.rnn.pad_packed_sequence(
            output, batch_first=True)[0].permute(0, 2, 1)


class RNNStateEncoder(nn.Module):
    """habitat_baselines' RNNStateEncoder (single-step forward)."""

    def __init__(self, input_size, hidden):
        super().__init__()
        self.rnn = nn.GRU(input_size, hidden)

    def forward(self, x, h, masks):
        out, h = self.rnn(x.unsqueeze(0), (h * masks).unsqueeze(0))
        return out.squeeze(0), h.squeeze(0)


# ---------------------------------------------------------------------------
# the networks (cma_policy.py CMANet, seq2seq_policy.py Seq2SeqNet)


class CMANet(nn.Module):
    def __init__(self, o, layout):
        super().__init__()
        hidden = o.hidden
        self._hidden_size = hidden
        self.instruction_encoder = InstructionEncoder(
            o.vocab, o.embedding, o.text_hidden, True, False)
        text = 2 * o.text_hidden
        self.depth_encoder = VlnResnetDepthEncoder(
            o.depth_arch, o.depth_base, o.depth_size, o.depth_out, True)
        if layout == "2020":
            self.rgb_encoder = TorchVisionResNet2020(o.rgb_out, True)
        else:
            self.rgb_encoder = TorchVisionResNet2021(
                o.rgb_arch, o.rgb_out, o.normalize_rgb, True)
        rgb_c = self.rgb_encoder.resnet_layer_size + 64
        depth_shape = self.depth_encoder.output_shape
        self.prev_action_embedding = nn.Embedding(5, 32)
        self.rgb_linear = nn.Sequential(
            nn.AdaptiveAvgPool1d(1), nn.Flatten(),
            nn.Linear(rgb_c, o.rgb_out), nn.ReLU(True))
        self.depth_linear = nn.Sequential(
            nn.Flatten(),
            nn.Linear(depth_shape[0] * depth_shape[1] * depth_shape[2],
                      o.depth_out), nn.ReLU(True))
        self.state_encoder = RNNStateEncoder(o.depth_out + o.rgb_out + 32,
                                             hidden)
        self.rgb_kv = nn.Conv1d(rgb_c, hidden // 2 + o.rgb_out, 1)
        self.depth_kv = nn.Conv1d(depth_shape[0], hidden // 2 + o.depth_out, 1)
        self.state_q = nn.Linear(hidden, hidden // 2)
        self.text_k = nn.Conv1d(text, hidden // 2, 1)
        self.text_q = nn.Linear(text, hidden // 2)
        self.register_buffer("_scale",
                             torch.tensor(1.0 / ((hidden // 2)**0.5)))
        self.second_state_compress = nn.Sequential(
            nn.Linear(hidden + o.rgb_out + o.depth_out + text + 32, hidden),
            nn.ReLU(True))
        self.second_state_encoder = RNNStateEncoder(hidden, hidden)
        self.progress_monitor = nn.Linear(hidden, 1)
        self.num_layers = 2

    def _attn(self, q, k, v, mask=None):
        logits = torch.einsum("nc, nci -> ni", q, k)
        if mask is not None:
            logits = logits - mask.float() * 1e8
        attn = F.softmax(logits * self._scale, dim=1)
        return torch.einsum("ni, nci -> nc", attn, v)

    def forward(self, obs, h, prev_actions, masks):
        instruction = self.instruction_encoder(obs["instruction"])
        depth = torch.flatten(self.depth_encoder(obs["depth"]), 2)
        rgb = torch.flatten(self.rgb_encoder(obs["rgb"]), 2)
        prev = self.prev_action_embedding(
            ((prev_actions.float() + 1) * masks).long().view(-1))
        state_in = torch.cat([self.rgb_linear(rgb), self.depth_linear(depth),
                              prev], dim=1)
        state, h0 = self.state_encoder(state_in, h[0], masks)
        text_mask = (instruction == 0.0).all(dim=1)
        text = self._attn(self.state_q(state), self.text_k(instruction),
                          instruction, text_mask)
        half = self._hidden_size // 2
        rgb_k, rgb_v = torch.split(self.rgb_kv(rgb), half, dim=1)
        depth_k, depth_v = torch.split(self.depth_kv(depth), half, dim=1)
        text_q = self.text_q(text)
        x = torch.cat([state, text, self._attn(text_q, rgb_k, rgb_v),
                       self._attn(text_q, depth_k, depth_v), prev], dim=1)
        x, h1 = self.second_state_encoder(self.second_state_compress(x), h[1],
                                          masks)
        return x, torch.stack([h0, h1])


class Seq2SeqNet(nn.Module):
    def __init__(self, o, layout):
        super().__init__()
        self.use_prev_action = o.prev_action
        self.instruction_encoder = InstructionEncoder(
            o.vocab, o.embedding, o.text_hidden, False, True)
        self.depth_encoder = VlnResnetDepthEncoder(
            o.depth_arch, o.depth_base, o.depth_size, o.depth_out, False)
        if layout == "2020":
            self.rgb_encoder = TorchVisionResNet2020(o.rgb_out, False)
        else:
            self.rgb_encoder = TorchVisionResNet2021(
                o.rgb_arch, o.rgb_out, o.normalize_rgb, False)
        size = o.text_hidden + o.depth_out + o.rgb_out
        if o.prev_action:
            self.prev_action_embedding = nn.Embedding(5, 32)
            size += 32
        self.state_encoder = RNNStateEncoder(size, o.hidden)
        self.progress_monitor = nn.Linear(o.hidden, 1)
        self.num_layers = 1

    def forward(self, obs, h, prev_actions, masks):
        x = torch.cat([self.instruction_encoder(obs["instruction"]),
                       self.depth_encoder(obs["depth"]),
                       self.rgb_encoder(obs["rgb"])], dim=1)
        if self.use_prev_action:
            x = torch.cat([x, self.prev_action_embedding(
                ((prev_actions.float() + 1) * masks).long().view(-1))], dim=1)
        x, h0 = self.state_encoder(x, h[0], masks)
        return x, h0.unsqueeze(0)


class CategoricalNet(nn.Module):
    def __init__(self, inputs, outputs):
        super().__init__()
        self.linear = nn.Linear(inputs, outputs)


class CriticHead(nn.Module):
    def __init__(self, inputs):
        super().__init__()
        self.fc = nn.Linear(inputs, 1)


class Policy(nn.Module):
    """ILPolicy (2021) / habitat's Policy with its critic (2020)."""

    def __init__(self, net, hidden, layout):
        super().__init__()
        self.net = net
        self.action_distribution = CategoricalNet(hidden, 4)
        if layout == "2020":
            self.critic = CriticHead(hidden)

    def logits(self, obs, h, prev_actions, masks):
        x, h = self.net(obs, h, prev_actions, masks)
        return self.action_distribution.linear(x), h


# ---------------------------------------------------------------------------
# making checkpoints


def randomize(module, generator):
    """Random weights with some spread in every normalisation layer, and
    logits of order one."""
    with torch.no_grad():
        for m in module.modules():
            if isinstance(m, (nn.BatchNorm2d, nn.GroupNorm)):
                m.weight.uniform_(0.5, 1.5, generator=generator)
                m.bias.uniform_(-0.2, 0.2, generator=generator)
            if isinstance(m, nn.BatchNorm2d):
                m.running_mean.uniform_(-0.2, 0.2, generator=generator)
                m.running_var.uniform_(0.5, 2.0, generator=generator)
                m.num_batches_tracked.fill_(1234)
            if isinstance(m, nn.Embedding) and m.weight.requires_grad:
                m.weight.normal_(generator=generator)
        module.action_distribution.linear.weight.mul_(4.0)


def model_config(o, layout):
    cma = o.policy == "cma"
    model = {
        "ablate_depth": False, "ablate_rgb": False,
        "ablate_instruction": False,
        "INSTRUCTION_ENCODER": {
            "vocab_size": o.vocab, "use_pretrained_embeddings": True,
            "embedding_file": "data/datasets/R2R_VLNCE_v1-3_preprocessed/"
                              "embeddings.json.gz",
            "fine_tune_embeddings": False, "embedding_size": o.embedding,
            "hidden_size": o.text_hidden, "rnn_type": "LSTM",
            "final_state_only": not cma, "bidirectional": cma},
        "RGB_ENCODER": {"cnn_type": {"resnet50": "TorchVisionResNet50",
                                     "resnet18": "TorchVisionResNet18"}[
                                         o.rgb_arch],
                        "output_size": o.rgb_out},
        "DEPTH_ENCODER": {"cnn_type": "VlnResnetDepthEncoder",
                          "output_size": o.depth_out,
                          "backbone": o.depth_arch,
                          "ddppo_checkpoint": "data/ddppo-models/"
                                              "gibson-2plus-resnet50.pth"},
        "STATE_ENCODER": {"hidden_size": o.hidden, "rnn_type": "GRU"},
        "SEQ2SEQ": {"use_prev_action": o.prev_action},
        "PROGRESS_MONITOR": {"use": o.pm, "alpha": 1.0},
    }
    if layout == "2021":
        model["policy_name"] = "CMAPolicy" if cma else "Seq2SeqPolicy"
        model["normalize_rgb"] = o.normalize_rgb
        model["INSTRUCTION_ENCODER"]["sensor_uuid"] = "instruction"
        model["RGB_ENCODER"]["trainable"] = False
        model["DEPTH_ENCODER"]["trainable"] = False
    else:
        model["inflection_weight_coef"] = 3.2
        model["INSTRUCTION_ENCODER"]["max_length"] = 200
        model["CMA"] = {"use": cma, "rcm_state_encoder": False}
    task = {
        "ENVIRONMENT": {"MAX_EPISODE_STEPS": o.max_steps},
        "SIMULATOR": {
            "FORWARD_STEP_SIZE": 0.25, "TURN_ANGLE": 15,
            "HABITAT_SIM_V0": {"GPU_DEVICE_ID": 0, "ALLOW_SLIDING": True},
            "RGB_SENSOR": {"WIDTH": o.rgb_size, "HEIGHT": o.rgb_size,
                           "HFOV": 90, "POSITION": [0, 1.25, 0]},
            "DEPTH_SENSOR": {"WIDTH": o.depth_size, "HEIGHT": o.depth_size,
                             "HFOV": 90, "POSITION": [0, 1.25, 0],
                             "MIN_DEPTH": 0.0, "MAX_DEPTH": 10.0,
                             "NORMALIZE_DEPTH": True}},
        "TASK": {"SUCCESS_DISTANCE": 3.0},
    }
    config = {"BASE_TASK_CONFIG_PATH": "habitat_extensions/config/"
                                       "vlnce_task.yaml",
              "TORCH_GPU_ID": 0, "MODEL": model, "TASK_CONFIG": task}
    if layout == "2021":
        config["RL"] = {"POLICY": {"OBS_TRANSFORMS": {
            "ENABLED_TRANSFORMS": []}}}
    for assignment in o.set or []:
        key, text = assignment.split("=", 1)
        try:
            value = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            value = text  # a bare word; [a, b] is a list of bare words
            if text.startswith("[") and text.endswith("]"):
                value = [w.strip() for w in text[1:-1].split(",") if w.strip()]
        node = config
        *path, leaf = key.split(".")
        for part in path:
            node = node.setdefault(part, {})
        node[leaf] = value
    return config


def build_policy(o, layout):
    net = (CMANet if o.policy == "cma" else Seq2SeqNet)(o, layout)
    policy = Policy(net, o.hidden, layout)
    randomize(policy, torch.Generator().manual_seed(o.seed))
    return policy.eval()


def random_inputs(o, generator):
    steps, batch = o.steps, 2
    lengths = [o.tokens, max(1, o.tokens - 3)]
    tokens = torch.zeros(batch, o.tokens + 2, dtype=torch.long)
    for b, n in enumerate(lengths):
        tokens[b, :n] = torch.randint(1, o.vocab, (n,), generator=generator)
    not_done = torch.ones(steps, batch)
    not_done[0] = 0
    if steps > 2:
        not_done[2, 1] = 0  # the second episode restarts
    return {
        "rgb": torch.randint(0, 256, (steps, batch, o.rgb_size, o.rgb_size, 3),
                             generator=generator, dtype=torch.uint8),
        "depth": torch.rand(steps, batch, o.depth_size, o.depth_size, 1,
                            generator=generator),
        "tokens": tokens,
        "prev_actions": torch.randint(0, 4, (steps, batch),
                                      generator=generator),
        "not_done": not_done,
    }


def run_steps(policy, io):
    """VLN-CE's evaluation loop: one step at a time, recurrent state in/out."""
    steps, batch = io["prev_actions"].shape
    h = torch.zeros(policy.net.num_layers, batch, policy.action_distribution
                    .linear.in_features)
    logits = []
    with torch.no_grad():
        for t in range(steps):
            obs = {"rgb": io["rgb"][t], "depth": io["depth"][t],
                   "instruction": io["tokens"]}
            out, h = policy.logits(obs, h, io["prev_actions"][t].unsqueeze(1),
                                   io["not_done"][t].unsqueeze(1))
            logits.append(out)
    return torch.stack(logits)


def save_checkpoint(path, state, config, attack=None, legacy=False):
    """torch.save as VLN-CE calls it; `legacy` writes the format of torch
    before 1.6 (not a zip), which the 2020 release was trained with."""
    config = Config(config)
    if attack:
        config["MODEL"]["EXTRA"] = Attack(f"touch {attack}")
    torch.save({"state_dict": state, "config": config}, path,
               _use_new_zipfile_serialization=not legacy)


def make(o, reference=True):
    torch.manual_seed(o.seed)
    policy = build_policy(o, o.layout)
    state = policy.state_dict()
    os.makedirs(o.out, exist_ok=True)
    if reference:
        io = random_inputs(o, torch.Generator().manual_seed(o.seed + 1))
        io["logits"] = run_steps(policy, io)
        tensor_archive(dict(state)).save(os.path.join(o.out, "source.pt"))
        tensor_archive(io).save(os.path.join(o.out, "io.pt"))
    if o.extra_key:
        state["net.extra_head.weight"] = torch.zeros(2, 3)
    if o.bad_shape:
        w = state["net.state_encoder.rnn.weight_hh_l0"]
        state["net.state_encoder.rnn.weight_hh_l0"] = torch.zeros(
            w.shape[0], w.shape[1] + 1)
    save_checkpoint(os.path.join(o.out, "vlnce.pth"), state,
                    model_config(o, o.layout), o.attack, o.legacy_format)


# ---------------------------------------------------------------------------
# our tensors under VLN-CE's names (the e2e test's source checkpoint)


def vlnce_names(ours_policy, ours_rgb, ours_depth, cma, layout):
    state = {}
    sequential = {"conv1": "0", "bn1": "1", "layer1": "4", "layer2": "5",
                  "layer3": "6", "layer4": "7"}
    for name, t in ours_rgb.items():
        head, rest = name.split(".", 1)
        if layout == "2021":
            head = sequential[head]
        state[f"net.rgb_encoder.cnn.{head}.{rest}"] = t
    for name, t in ours_depth.items():
        state["net.depth_encoder.visual_encoder." + name] = t
    rename = {
        "instruction_encoder.embedding": "net.instruction_encoder."
                                         "embedding_layer",
        "instruction_encoder.lstm": "net.instruction_encoder.encoder_rnn",
        "state_encoder.gru": "net.state_encoder.rnn",
        "second_state_encoder.gru": "net.second_state_encoder.rnn",
        "action_head": "action_distribution.linear",
        "rgb_spatial_embedding": "net.rgb_encoder.spatial_embeddings",
        "depth_spatial_embedding": "net.depth_encoder.spatial_embeddings",
        "second_state_compress": "net.second_state_compress.0",
        "rgb_linear": "net.rgb_linear.2" if cma else (
            "net.rgb_encoder.fc" if layout == "2020" else
            "net.rgb_encoder.fc.1"),
        "depth_linear": ("net.depth_linear.1" if cma else
                         "net.depth_encoder.visual_fc.1"),
    }
    hidden = ours_policy["action_head.weight"].shape[1]
    for name, t in ours_policy.items():
        module, leaf = name.rsplit(".", 1)
        target = rename.get(module, "net." + module)
        if module in ("rgb_kv", "depth_kv", "text_k") and leaf == "weight":
            t = t.unsqueeze(2)
        state[f"{target}.{leaf}"] = t
    if "net.progress_monitor.weight" not in state:
        state["net.progress_monitor.weight"] = torch.zeros(1, hidden)
        state["net.progress_monitor.bias"] = torch.zeros(1)
    if cma:
        state["net._scale"] = torch.tensor(1.0 / ((hidden // 2)**0.5))
    return state


def from_ours(o):
    policy = dict(torch.jit.load(o.policy_file).named_buffers())
    rgb = dict(torch.jit.load(o.rgb_file).named_buffers())
    depth = dict(torch.jit.load(o.depth_file).named_buffers())
    if o.layout != "2021":
        sys.exit("vlnce_reference.py from-ours: writes the 2021 layout only")
    state = vlnce_names(policy, rgb, depth, o.policy == "cma", o.layout)
    os.makedirs(os.path.dirname(os.path.abspath(o.out)), exist_ok=True)
    save_checkpoint(o.out, state, model_config(o, o.layout))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    make_parser = sub.add_parser("make")
    make_parser.add_argument("out")
    many_parser = sub.add_parser("make-many")
    many_parser.add_argument("dir")
    many_parser.add_argument("cases", nargs="+")
    ours_parser = sub.add_parser("from-ours")
    for name in ("out", "policy_file", "rgb_file", "depth_file"):
        ours_parser.add_argument(name)
    for p in (make_parser, ours_parser):
        p.add_argument("--policy", choices=("cma", "seq2seq"), default="cma")
        p.add_argument("--layout", choices=("2020", "2021"), default="2021")
        p.add_argument("--pm", action="store_true")
        p.add_argument("--prev-action", action="store_true")
        p.add_argument("--normalize-rgb", action="store_true")
        p.add_argument("--rgb-arch", default="resnet18")
        p.add_argument("--depth-arch", default="resnet18")
        p.add_argument("--depth-base", type=int, default=8)
        p.add_argument("--rgb-size", type=int, default=32)
        p.add_argument("--depth-size", type=int, default=64)
        p.add_argument("--vocab", type=int, default=13)
        p.add_argument("--embedding", type=int, default=5)
        p.add_argument("--text-hidden", type=int, default=6)
        p.add_argument("--hidden", type=int, default=16)
        p.add_argument("--rgb-out", type=int, default=8)
        p.add_argument("--depth-out", type=int, default=6)
        p.add_argument("--max-steps", type=int, default=500)
        p.add_argument("--steps", type=int, default=4)
        p.add_argument("--tokens", type=int, default=5)
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--set", action="append",
                       help="KEY=VALUE of the pickled config")
        p.add_argument("--extra-key", action="store_true")
        p.add_argument("--bad-shape", action="store_true")
        p.add_argument("--attack", help="file that os.system would touch")
        p.add_argument("--legacy-format", action="store_true",
                       help="torch.save's format before torch 1.6")
    def parse(argv):
        o = parser.parse_args(argv)
        if getattr(o, "layout", None) == "2020":
            o.rgb_arch = "resnet50"  # the release's only RGB encoder
        return o

    o = parse(sys.argv[1:])
    if o.command == "make-many":
        for case in o.cases:
            name, args = case.split(":", 1)
            make(parse(["make", os.path.join(o.dir, name.strip())] +
                       shlex.split(args)), reference=False)
    else:
        (make if o.command == "make" else from_ours)(o)


if __name__ == "__main__":
    main()
