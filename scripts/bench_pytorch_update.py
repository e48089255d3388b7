#!/usr/bin/env python3
"""Eager-PyTorch peer of `vlnce-bench update`: one VLN-CE teacher-forcing
update on cached features, timed the same way.

This re-states VLN-CE's sequence-mode design (vlnce_baselines CMANet /
Seq2SeqNet with habitat_baselines' RNNStateEncoder, as trained by the DAgger
trainer from cached "rgb_features"/"depth_features"), written for this
benchmark so that it needs only torch:
  - observations are flattened to T*B rows and every row carries its
    instruction, so the instruction LSTM runs on T*B packed sequences;
  - the learned position embeddings are concatenated to the feature maps
    and the key/value 1x1 convolutions project every location;
  - the GRUs run over the whole sequence, cut where an episode starts.
Loss: inflection-weighted cross-entropy (sum w*CE / sum w per episode, mean
over the batch) plus the progress monitor's MSE over the real steps; then
backward and Adam (lr 2.5e-4). Same sizes, batch layout and random data
distribution as apps/BenchMain.cpp.

    /usr/bin/python3 scripts/bench_pytorch_update.py --model cma --batch 5 \
        --steps 60 --instr-len 30 --threads 2

--scale cpu takes configs/main.yaml's model instead (small-CNN features,
hidden 128, 151 words, embeddings trained, no progress monitor), as
`vlnce-bench update --scale cpu` does.

Needs only Debian's python3-torch (scripts/setup.sh installs it).
"""
import argparse
import statistics
import time

import torch
import torch.nn as nn
import torch.nn.functional as F

NUM_ACTIONS = 4
VOCAB = 2504
EMBED = 50
INSTR_HIDDEN = 128
HIDDEN = 512
RGB_SHAPE = (2048, 4, 4)  # torchvision ResNet-50, adaptive-pooled
DEPTH_SHAPE = (128, 4, 4)  # DD-PPO ResNet-50 on 256x256 depth
RGB_OUT = 256
DEPTH_OUT = 128
POS_DIM = 64
PREV_DIM = 32
TRAIN_EMBEDDINGS = False
PROGRESS_MONITOR = True


def use_cpu_scale():
    """configs/main.yaml's model (configs/vln/cpu_base.yaml)."""
    global VOCAB, HIDDEN, RGB_SHAPE, DEPTH_SHAPE, TRAIN_EMBEDDINGS
    global PROGRESS_MONITOR
    VOCAB = 151
    HIDDEN = 128
    RGB_SHAPE = (64, 4, 4)  # the small CNN on 64x64 RGB
    DEPTH_SHAPE = (32, 4, 4)  # the small CNN on 64x64 depth
    TRAIN_EMBEDDINGS = True
    PROGRESS_MONITOR = False


class InstructionEncoder(nn.Module):
    def __init__(self, bidirectional, final_state_only):
        super().__init__()
        self.embedding = nn.Embedding.from_pretrained(
            torch.randn(VOCAB, EMBED), freeze=not TRAIN_EMBEDDINGS)
        self.lstm = nn.LSTM(EMBED, INSTR_HIDDEN, bidirectional=bidirectional)
        self.final_state_only = final_state_only
        self.output_size = INSTR_HIDDEN * (2 if bidirectional else 1)

    def forward(self, tokens):
        lengths = (tokens != 0).long().sum(dim=1)
        packed = nn.utils.rnn.pack_padded_sequence(
            self.embedding(tokens), lengths.cpu(), batch_first=True,
            enforce_sorted=False)
        output, (h, _) = self.lstm(packed)
        if self.final_state_only:
            return h.squeeze(0)
        # [N, D, L], zeros past each length
        return nn.utils.rnn.pad_packed_sequence(
            output, batch_first=True)[0].permute(0, 2, 1)


class StateEncoder(nn.Module):
    """GRU over [T*N, ...] rows, state reset where masks == 0."""

    def __init__(self, input_size, hidden_size):
        super().__init__()
        self.rnn = nn.GRU(input_size, hidden_size)
        for name, p in self.rnn.named_parameters():
            if "weight" in name:
                nn.init.orthogonal_(p)
            else:
                nn.init.constant_(p, 0)

    def forward(self, x, hidden, masks):
        n = hidden.size(0)
        t = x.size(0) // n
        x = x.view(t, n, -1)
        masks = masks.view(t, n)
        zeros = (masks[1:] == 0.0).any(dim=-1).nonzero().squeeze(-1)
        starts = [0] + (zeros + 1).tolist() + [t]
        h = hidden.unsqueeze(0)
        outputs = []
        for i in range(len(starts) - 1):
            s, e = starts[i], starts[i + 1]
            out, h = self.rnn(x[s:e], h * masks[s].view(1, -1, 1))
            outputs.append(out)
        return torch.cat(outputs, dim=0).view(t * n, -1), h.squeeze(0)


def spatial(features, embedding):
    b, _, h, w = features.size()
    pos = embedding(torch.arange(embedding.num_embeddings)).view(
        1, -1, h, w).expand(b, embedding.embedding_dim, h, w)
    return torch.cat([features, pos], dim=1)


class CMANet(nn.Module):
    def __init__(self):
        super().__init__()
        self.instruction_encoder = InstructionEncoder(True, False)
        self.rgb_spatial = nn.Embedding(16, POS_DIM)
        self.depth_spatial = nn.Embedding(16, POS_DIM)
        rgb_c = RGB_SHAPE[0] + POS_DIM
        depth_c = DEPTH_SHAPE[0] + POS_DIM
        self.prev_action_embedding = nn.Embedding(NUM_ACTIONS + 1, PREV_DIM)
        self.rgb_linear = nn.Sequential(
            nn.AdaptiveAvgPool1d(1), nn.Flatten(),
            nn.Linear(rgb_c, RGB_OUT), nn.ReLU(True))
        self.depth_linear = nn.Sequential(
            nn.Flatten(), nn.Linear(depth_c * 16, DEPTH_OUT), nn.ReLU(True))
        self.state_encoder = StateEncoder(RGB_OUT + DEPTH_OUT + PREV_DIM,
                                          HIDDEN)
        text = self.instruction_encoder.output_size
        self.rgb_kv = nn.Conv1d(rgb_c, HIDDEN // 2 + RGB_OUT, 1)
        self.depth_kv = nn.Conv1d(depth_c, HIDDEN // 2 + DEPTH_OUT, 1)
        self.state_q = nn.Linear(HIDDEN, HIDDEN // 2)
        self.text_k = nn.Conv1d(text, HIDDEN // 2, 1)
        self.text_q = nn.Linear(text, HIDDEN // 2)
        self.register_buffer("_scale",
                             torch.tensor(1.0 / ((HIDDEN // 2) ** 0.5)))
        self.second_state_compress = nn.Sequential(
            nn.Linear(HIDDEN + RGB_OUT + DEPTH_OUT + text + PREV_DIM, HIDDEN),
            nn.ReLU(True))
        self.second_state_encoder = StateEncoder(HIDDEN, HIDDEN)
        self.action_head = nn.Linear(HIDDEN, NUM_ACTIONS)
        self.progress_monitor = nn.Linear(HIDDEN, 1)

    def _attn(self, q, k, v, mask=None):
        logits = torch.einsum("nc, nci -> ni", q, k)
        if mask is not None:
            logits = logits - mask.float() * 1e8
        attn = F.softmax(logits * self._scale, dim=1)
        return torch.einsum("ni, nci -> nc", attn, v)

    def forward(self, obs, hidden, prev_actions, masks):
        instruction = self.instruction_encoder(obs["instruction"])
        depth = torch.flatten(spatial(obs["depth_features"],
                                      self.depth_spatial), 2)
        rgb = torch.flatten(spatial(obs["rgb_features"], self.rgb_spatial), 2)
        prev = self.prev_action_embedding(
            ((prev_actions.float() + 1) * masks).long().view(-1))
        rgb_in = self.rgb_linear(rgb)
        depth_in = self.depth_linear(depth)
        state, h1 = self.state_encoder(
            torch.cat([rgb_in, depth_in, prev], dim=1), hidden[:, 0], masks)
        text_mask = (instruction == 0.0).all(dim=1)
        text = self._attn(self.state_q(state), self.text_k(instruction),
                          instruction, text_mask)
        # keys, then values (VLN-CE splits by HIDDEN // 2, the same at its
        # hidden 512; explicit sizes also hold at hidden 128)
        rgb_k, rgb_v = torch.split(self.rgb_kv(rgb), [HIDDEN // 2, RGB_OUT],
                                   dim=1)
        depth_k, depth_v = torch.split(self.depth_kv(depth),
                                       [HIDDEN // 2, DEPTH_OUT], dim=1)
        text_q = self.text_q(text)
        rgb_att = self._attn(text_q, rgb_k, rgb_v)
        depth_att = self._attn(text_q, depth_k, depth_v)
        x = self.second_state_compress(
            torch.cat([state, text, rgb_att, depth_att, prev], dim=1))
        x, h2 = self.second_state_encoder(x, hidden[:, 1], masks)
        return (self.action_head(x), torch.tanh(self.progress_monitor(x)),
                torch.stack([h1, h2], dim=1))


class Seq2SeqNet(nn.Module):
    def __init__(self):
        super().__init__()
        self.instruction_encoder = InstructionEncoder(False, True)
        self.rgb_fc = nn.Linear(RGB_SHAPE[0], RGB_OUT)
        self.depth_fc = nn.Sequential(
            nn.Flatten(), nn.Linear(DEPTH_SHAPE[0] * 16, DEPTH_OUT),
            nn.ReLU(True))
        self.state_encoder = StateEncoder(INSTR_HIDDEN + RGB_OUT + DEPTH_OUT,
                                          HIDDEN)
        self.action_head = nn.Linear(HIDDEN, NUM_ACTIONS)
        self.progress_monitor = nn.Linear(HIDDEN, 1)

    def forward(self, obs, hidden, prev_actions, masks):
        instruction = self.instruction_encoder(obs["instruction"])
        depth = self.depth_fc(obs["depth_features"])
        rgb = F.relu(self.rgb_fc(
            F.adaptive_avg_pool2d(obs["rgb_features"], 1).flatten(1)))
        x, h = self.state_encoder(torch.cat([instruction, depth, rgb], dim=1),
                                  hidden[:, 0], masks)
        return (self.action_head(x), torch.tanh(self.progress_monitor(x)),
                h.unsqueeze(1))


def make_batch(args):
    """Same layout and distributions as makeBatch() in apps/BenchMain.cpp."""
    t_max, b = args.steps, args.batch
    lengths = torch.randint(t_max // 2, t_max + 1, (b,))
    lengths[0] = t_max
    tokens = torch.zeros(b, args.instr_len, dtype=torch.long)
    for i in range(b):
        words = args.instr_len if i == 0 else int(
            torch.randint(args.instr_len // 2, args.instr_len + 1, (1,)))
        tokens[i, :words] = torch.randint(1, VOCAB, (words,))
    draw = torch.rand(t_max, b)
    actions = torch.where(draw < 0.7, torch.ones(t_max, b, dtype=torch.long),
                          torch.where(draw < 0.85,
                                      torch.full((t_max, b), 2),
                                      torch.full((t_max, b), 3)))
    t = torch.arange(t_max).unsqueeze(1).expand(t_max, b)
    valid = t < lengths.unsqueeze(0)
    actions = torch.where(t == lengths.unsqueeze(0) - 1,
                          torch.zeros_like(actions), actions)
    prev_actions = torch.cat([torch.zeros(1, b, dtype=torch.long),
                              actions[:-1]])
    masks = torch.ones(t_max, b)
    masks[0] = 0
    inflections = torch.cat([torch.ones(1, b, dtype=torch.bool),
                             actions[1:] != actions[:-1]])
    weights = torch.where(inflections, torch.tensor(3.2),
                          torch.tensor(1.0)) * valid.float()
    progress = (t.float() + 1) / lengths.unsqueeze(0)
    # VLN-CE: observations are [T*N, ...], every step carries its instruction
    obs = {
        "instruction": tokens.unsqueeze(0).expand(t_max, b, -1).reshape(
            t_max * b, -1),
        "rgb_features": F.relu(torch.randn(t_max * b, *RGB_SHAPE)),
        "depth_features": F.relu(torch.randn(t_max * b, *DEPTH_SHAPE)),
    }
    return (obs, prev_actions.view(-1, 1), masks.view(-1, 1), actions,
            weights, valid, progress)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", choices=["cma", "seq2seq"], default="cma")
    parser.add_argument("--scale", choices=["paper", "cpu"], default="paper")
    parser.add_argument("--batch", type=int, default=5)
    parser.add_argument("--steps", type=int, default=60)
    parser.add_argument("--instr-len", type=int, default=30)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--iters", type=int, default=10)
    args = parser.parse_args()
    if args.scale == "cpu":
        use_cpu_scale()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)

    net = CMANet() if args.model == "cma" else Seq2SeqNet()
    net.train()
    optimizer = torch.optim.Adam(
        [p for p in net.parameters() if p.requires_grad], lr=2.5e-4)
    obs, prev_actions, masks, actions, weights, valid, progress = \
        make_batch(args)
    layers = 2 if args.model == "cma" else 1

    def update():
        optimizer.zero_grad(set_to_none=True)
        hidden = torch.zeros(args.batch, layers, HIDDEN)
        logits, progress_hat, _ = net(obs, hidden, prev_actions, masks)
        logits = logits.view(args.steps, args.batch, -1)
        ce = F.cross_entropy(logits.permute(0, 2, 1), actions,
                             reduction="none")
        action_loss = ((weights * ce).sum(0) / weights.sum(0)).mean()
        loss = action_loss
        if PROGRESS_MONITOR:
            mse = F.mse_loss(progress_hat.view(-1), progress.view(-1),
                             reduction="none")
            loss = loss + torch.masked_select(mse, valid.view(-1)).mean()
        loss.backward()
        optimizer.step()
        return loss.item()

    for _ in range(args.warmup):
        update()
    times = []
    cpu_start = time.process_time()
    for _ in range(args.iters):
        start = time.perf_counter()
        loss = update()
        times.append(1000.0 * (time.perf_counter() - start))
    cpu = 1000.0 * (time.process_time() - cpu_start) / args.iters
    print(f"pytorch update {args.model} scale={args.scale} "
          f"batch={args.batch} "
          f"steps={args.steps} instr_len={args.instr_len} "
          f"threads={args.threads}: median {statistics.median(times):.1f} "
          f"ms/update (min {min(times):.1f}, mean "
          f"{statistics.mean(times):.1f}, CPU {cpu:.1f} ms/update; "
          f"{args.iters} runs after {args.warmup} warm-up; last loss "
          f"{loss:.4f})")


if __name__ == "__main__":
    main()
