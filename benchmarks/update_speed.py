"""Gradient updates per second of SAC+DrQ and QT-Opt+DrQ on 84x84x(3*3) pixels, like for like.

    python benchmarks/update_speed.py [--batch-sizes 512 128] [--updates 2] [--rounds 3] [--warmup 2]
        [--variants reference ours ours+channels_last ours+compile ...]
        [--allocators glibc jemalloc glibc+retain glibc-nommap]

Every variant is built and warmed up (``--warmup`` updates, which also pays ``torch.compile``),
then all are timed in ``--rounds`` interleaved rounds of ``--updates`` updates (an even number:
the actor and the target networks update every second step, as DrQ's ``actor_update_frequency``
and ``critic_target_update_frequency`` of 2) on the same uint8 batch; the median round is
reported, so that the load of other users of the machine hits every variant alike. Each
allocator setting runs in its own subprocess (the allocator is chosen at process start), and
one table with every ratio, CPU seconds and minor page faults per update is printed at the end.
With glibc, variants in one process share malloc's adaptive mmap threshold: at batch 128 the
activations (~28 MB) are near its 32 MB cap and timings can flip between two modes.

Variants:

* ``reference``: the update of the reference DrQ code, rebuilt here in plain PyTorch: actor and
  critic each with an encoder (convolutions tied), ``obs / 255`` on the input, out-of-place
  ReLUs in the encoder, the two augmented copies encoded by separate passes, the actor update
  re-encoding the observation after the critic step, separate backward passes, float images
  augmented by replicate padding + bilinear ``grid_sample`` (what kornia's crop does).
* ``ours``: :class:`dcs_torchrl.objectives.DrQSACLoss` / :class:`QTOptLoss` with uint8
  :class:`RandomShift` (one gather), each image batch encoded once per encoder, 1/255 folded
  into the first convolution, in-place ReLUs, one backward pass.
* ``+channels_last``: the convolutions in NHWC; ``+compile``: ``torch.compile`` on the encoder.
* ``qtopt reference``: the same QT-Opt+DrQ update with the reference's habits (a pass per copy,
  ``/ 255``, out-of-place ReLU, CEM per copy).

Allocators: ``glibc`` (default malloc), ``jemalloc`` (``LD_PRELOAD`` of Debian's libjemalloc2 with
``MALLOC_CONF=dirty_decay_ms:-1,muzzy_decay_ms:-1``, see docs/performance.md), ``glibc-nommap`` (glibc with
``GLIBC_TUNABLES`` that keep freed memory in the heap: no ``mmap`` for large blocks, no trimming),
``glibc+retain`` (the same set at run time by :func:`dcs_torchrl.modules.retain_freed_memory`).
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import time
import warnings

import torch
import torch.nn.functional as F
from torch import nn

JEMALLOC = "/usr/lib/x86_64-linux-gnu/libjemalloc.so.2"
ALLOCATORS = {
    "glibc": {},
    "jemalloc": {"LD_PRELOAD": JEMALLOC, "MALLOC_CONF": "dirty_decay_ms:-1,muzzy_decay_ms:-1"},
    "glibc-nommap": {"GLIBC_TUNABLES": "glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=68719476736"},
    "glibc+retain": {"DCS_BENCH_RETAIN_FREED_MEMORY": "1"},  # dcs_torchrl.modules.retain_freed_memory()
}
SAC_VARIANTS = ["reference", "ours", "ours+channels_last", "ours+compile", "ours+compile+channels_last"]
QTOPT_VARIANTS = ["qtopt reference", "qtopt ours", "qtopt ours+channels_last"]
ACTION_DIM = 6  # cheetah / walker
FRAME_STACK = 3
DISCOUNT, TAU, LR = 0.99, 0.01, 1e-3  # DrQ config.yaml


# ---------------------------------------------------------------------------------------------
# The reference DrQ update, rebuilt in plain PyTorch (same architecture and update order).
# ---------------------------------------------------------------------------------------------
def _ref_mlp(inp, hidden, out):
    net = nn.Sequential(nn.Linear(inp, hidden), nn.ReLU(inplace=True), nn.Linear(hidden, hidden), nn.ReLU(inplace=True), nn.Linear(hidden, out))
    for m in net:
        if isinstance(m, nn.Linear):
            nn.init.orthogonal_(m.weight)
            nn.init.zeros_(m.bias)
    return net


class RefEncoder(nn.Module):
    def __init__(self, channels):
        super().__init__()
        self.convs = nn.ModuleList([nn.Conv2d(channels, 32, 3, stride=2)] + [nn.Conv2d(32, 32, 3) for _ in range(3)])
        self.head = nn.Sequential(nn.Linear(32 * 35 * 35, 50), nn.LayerNorm(50))

    def forward(self, obs, detach=False):
        x = obs / 255.0
        for conv in self.convs:
            x = torch.relu(conv(x))
        h = x.reshape(x.size(0), -1)
        if detach:
            h = h.detach()
        return torch.tanh(self.head(h))


class RefActor(nn.Module):
    def __init__(self, channels, hidden):
        super().__init__()
        self.encoder = RefEncoder(channels)
        self.trunk = _ref_mlp(50, hidden, 2 * ACTION_DIM)

    def forward(self, obs, detach_encoder=False):
        mu, log_std = self.trunk(self.encoder(obs, detach=detach_encoder)).chunk(2, dim=-1)
        log_std = -10.0 + 0.5 * 12.0 * (torch.tanh(log_std) + 1)
        base = torch.distributions.Normal(mu, log_std.exp())
        return torch.distributions.TransformedDistribution(base, [torch.distributions.TanhTransform(cache_size=1)])


class RefCritic(nn.Module):
    def __init__(self, channels, hidden):
        super().__init__()
        self.encoder = RefEncoder(channels)
        self.q1 = _ref_mlp(50 + ACTION_DIM, hidden, 1)
        self.q2 = _ref_mlp(50 + ACTION_DIM, hidden, 1)

    def forward(self, obs, action, detach_encoder=False):
        h = torch.cat([self.encoder(obs, detach=detach_encoder), action], dim=-1)
        return self.q1(h), self.q2(h)


def ref_augment(obs, pad=4):
    """Replicate pad + random crop by bilinear sampling at integer offsets (kornia-style)."""
    n, _, h, w = obs.shape
    padded = F.pad(obs, (pad, pad, pad, pad), mode="replicate")
    eps = 1.0 / (h + 2 * pad)
    arange = torch.linspace(-1.0 + eps, 1.0 - eps, h + 2 * pad, device=obs.device)[:h]
    base = torch.stack(torch.meshgrid(arange, arange, indexing="xy"), dim=-1).unsqueeze(0).expand(n, h, w, 2)
    shift = torch.randint(0, 2 * pad + 1, (n, 1, 1, 2), device=obs.device).float() * (2.0 / (h + 2 * pad))
    return F.grid_sample(padded, base + shift, padding_mode="zeros", align_corners=False)


class ReferenceSAC:
    def __init__(self, channels, hidden, device="cpu"):
        self.actor = RefActor(channels, hidden).to(device)
        self.critic = RefCritic(channels, hidden).to(device)
        self.critic_target = copy.deepcopy(self.critic)
        for a, c in zip(self.actor.encoder.convs, self.critic.encoder.convs):  # tie the convolutions
            a.weight, a.bias = c.weight, c.bias
        self.log_alpha = torch.tensor(math.log(0.1), requires_grad=True, device=device)
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=LR)
        self.critic_opt = torch.optim.Adam(self.critic.parameters(), lr=LR)
        self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=LR)
        self.step = 0

    def update(self, batch):
        pixels, action, reward, next_pixels = batch
        obs, next_obs = pixels.float(), next_pixels.float()
        obs_aug, obs = ref_augment(obs), ref_augment(obs)
        next_obs_aug, next_obs = ref_augment(next_obs), ref_augment(next_obs)
        alpha = self.log_alpha.exp().detach()
        with torch.no_grad():
            target = 0
            for nxt in (next_obs, next_obs_aug):
                dist = self.actor(nxt)
                a = dist.rsample()
                logp = dist.log_prob(a).sum(-1, keepdim=True)
                t1, t2 = self.critic_target(nxt, a)
                target = target + reward + DISCOUNT * (torch.min(t1, t2) - alpha * logp)
            target = target / 2
        q1, q2 = self.critic(obs, action)
        loss = F.mse_loss(q1, target) + F.mse_loss(q2, target)
        q1, q2 = self.critic(obs_aug, action)
        loss = loss + F.mse_loss(q1, target) + F.mse_loss(q2, target)
        self.critic_opt.zero_grad()
        loss.backward()
        self.critic_opt.step()
        if self.step % 2 == 0:
            dist = self.actor(obs, detach_encoder=True)
            a = dist.rsample()
            logp = dist.log_prob(a).sum(-1, keepdim=True)
            q1, q2 = self.critic(obs, a, detach_encoder=True)
            actor_loss = (alpha * logp - torch.min(q1, q2)).mean()
            self.actor_opt.zero_grad()
            actor_loss.backward()
            self.actor_opt.step()
            alpha_loss = (self.log_alpha.exp() * (-logp - (-ACTION_DIM)).detach()).mean()
            self.alpha_opt.zero_grad()
            alpha_loss.backward()
            self.alpha_opt.step()
            with torch.no_grad():
                for p, tp in zip(self.critic.parameters(), self.critic_target.parameters()):
                    tp.lerp_(p, TAU)
        self.step += 1


class ReferenceQTOpt:
    """QT-Opt+DrQ with the reference's habits: a pass per copy, /255, out-of-place ReLU, CEM per copy."""

    def __init__(self, channels, hidden, device="cpu"):
        self.critic = RefCritic(channels, hidden).to(device)
        self.critic_target = copy.deepcopy(self.critic)
        self.opt = torch.optim.Adam(self.critic.parameters(), lr=LR)
        self.step = 0

    def _cem(self, emb, q):
        n = emb.shape[0]
        mean, std = torch.zeros(n, ACTION_DIM, device=emb.device), torch.ones(n, ACTION_DIM, device=emb.device)
        for _ in range(2):
            a = (mean.unsqueeze(1) + std.unsqueeze(1) * torch.randn(n, 64, ACTION_DIM, device=emb.device)).clamp(-1, 1)
            v = q(torch.cat([emb.unsqueeze(1).expand(n, 64, 50), a], -1)).squeeze(-1)
            idx = v.topk(6, dim=1).indices
            elites = a.gather(1, idx.unsqueeze(-1).expand(n, 6, ACTION_DIM))
            mean, std = elites.mean(1), elites.std(1)
        return elites[:, 0]

    def update(self, batch):
        pixels, action, reward, next_pixels = batch
        obs, next_obs = pixels.float(), next_pixels.float()
        copies = [(ref_augment(obs), ref_augment(next_obs)) for _ in range(2)]
        vmax = 1.0 / (1 - DISCOUNT)
        with torch.no_grad():
            value = 0
            for _, nxt in copies:
                emb = self.critic_target.encoder(nxt)
                a = self._cem(emb, self.critic_target.q1)
                h = torch.cat([emb, a], -1)
                value = value + vmax * torch.sigmoid(torch.min(self.critic_target.q1(h), self.critic_target.q2(h)))
            target = ((reward + DISCOUNT * value / 2) / vmax).clamp(0, 1)
        p1 = p2 = 0
        for o, _ in copies:
            q1, q2 = self.critic(o, action)
            p1, p2 = p1 + torch.sigmoid(q1) / 2, p2 + torch.sigmoid(q2) / 2
        loss = F.binary_cross_entropy(p1, target) + F.binary_cross_entropy(p2, target)
        self.opt.zero_grad()
        loss.backward()
        self.opt.step()
        if self.step % 2 == 0:
            with torch.no_grad():
                for p, tp in zip(self.critic.parameters(), self.critic_target.parameters()):
                    tp.lerp_(p, TAU)
        self.step += 1


# ---------------------------------------------------------------------------------------------
# Ours
# ---------------------------------------------------------------------------------------------
class OursSAC:
    def __init__(self, channels, hidden, channels_last=False, compile=False):
        from torchrl.data import Bounded
        from torchrl.objectives import SoftUpdate

        from dcs_torchrl.modules import RandomShift, make_critic, make_encoder, make_sac_actor, with_next_keys
        from dcs_torchrl.objectives import DrQSACLoss

        spec = Bounded(-1.0, 1.0, shape=(ACTION_DIM,))
        encoder = make_encoder((channels, 84, 84), channels_last=channels_last, compile=compile)
        actor = make_sac_actor(spec, 50, hidden_dim=hidden)
        critics = [make_critic(spec, 50, hidden_dim=hidden) for _ in range(2)]
        self.loss = DrQSACLoss(actor, critics, encoder=encoder, num_augmentations=2, augmentation=RandomShift(4, in_keys=with_next_keys(["pixels"])))
        self.updater = SoftUpdate(self.loss, tau=TAU)
        self.critic_opt = torch.optim.Adam([*self.loss.qvalue_network_params.values(True, True), *self.loss.encoder_network_params.values(True, True)], lr=LR)
        self.actor_opt = torch.optim.Adam(self.loss.actor_network_params.values(True, True), lr=LR)
        self.alpha_opt = torch.optim.Adam([self.loss.log_alpha], lr=LR)
        self.step = 0

    def update(self, data):
        out = self.loss(data)
        update_actor = self.step % 2 == 0
        total = out["loss_qvalue"] + (out["loss_actor"] + out["loss_alpha"] if update_actor else 0)
        for opt in (self.critic_opt, self.actor_opt, self.alpha_opt):
            opt.zero_grad()
        total.backward()
        self.critic_opt.step()
        if update_actor:
            self.actor_opt.step()
            self.alpha_opt.step()
            self.updater.step()
        self.step += 1


class OursQTOpt:
    def __init__(self, channels, hidden, channels_last=False):
        from torchrl.data import Bounded
        from torchrl.objectives import SoftUpdate

        from dcs_torchrl.modules import RandomShift, make_critic, make_encoder, with_next_keys
        from dcs_torchrl.objectives import QTOptLoss

        spec = Bounded(-1.0, 1.0, shape=(ACTION_DIM,))
        encoder = make_encoder((channels, 84, 84), channels_last=channels_last)
        heads = [make_critic(spec, 50, hidden_dim=hidden) for _ in range(2)]
        self.loss = QTOptLoss(heads, encoder=encoder, action_spec=spec, num_augmentations=2, augmentation=RandomShift(4, in_keys=with_next_keys(["pixels"])))
        self.updater = SoftUpdate(self.loss, tau=TAU)
        self.opt = torch.optim.Adam(self.loss.parameters(), lr=LR)
        self.step = 0

    def update(self, data):
        out = self.loss(data)
        self.opt.zero_grad()
        out["loss_qvalue"].backward()
        self.opt.step()
        if self.step % 2 == 0:
            self.updater.step()
        self.step += 1


def make_agent(variant, channels, hidden):
    if variant == "reference":
        return ReferenceSAC(channels, hidden), "tensors"
    if variant == "qtopt reference":
        return ReferenceQTOpt(channels, hidden), "tensors"
    if variant.startswith("qtopt ours"):
        return OursQTOpt(channels, hidden, channels_last="channels_last" in variant), "tensordict"
    return OursSAC(channels, hidden, channels_last="channels_last" in variant, compile="compile" in variant), "tensordict"


def make_batch(batch_size, channels, kind):
    from tensordict import TensorDict

    gen = torch.Generator().manual_seed(0)
    pixels = torch.randint(0, 256, (2, batch_size, channels, 84, 84), generator=gen, dtype=torch.int64).to(torch.uint8)
    action = 2 * torch.rand(batch_size, ACTION_DIM, generator=gen) - 1
    reward = torch.rand(batch_size, 1, generator=gen)
    if kind == "tensors":
        return pixels[0], action, reward, pixels[1]
    return TensorDict(
        {
            "pixels": pixels[0], "action": action, ("next", "pixels"): pixels[1], ("next", "reward"): reward,
            ("next", "done"): torch.zeros(batch_size, 1, dtype=torch.bool),
            ("next", "terminated"): torch.zeros(batch_size, 1, dtype=torch.bool),
        },
        [batch_size],
    )


def _minor_faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def measure(variants, batch_size, updates, rounds, warmup, hidden):
    """All variants built and warmed up, then timed in interleaved rounds (machine noise hits
    every variant alike); the median round is reported."""
    channels = 3 * FRAME_STACK
    agents = {}
    for variant in variants:
        torch.manual_seed(0)
        agent, kind = make_agent(variant, channels, hidden)
        batch = make_batch(batch_size, channels, kind)
        start = time.perf_counter()
        for _ in range(warmup):
            agent.update(batch if kind == "tensors" else batch.clone(False))
        agents[variant] = (agent, kind, batch, time.perf_counter() - start)
    samples = {variant: [] for variant in variants}
    for _ in range(rounds):
        for variant, (agent, kind, batch, _) in agents.items():
            faults, cpu, wall = _minor_faults(), time.process_time(), time.perf_counter()
            for _ in range(updates):
                agent.update(batch if kind == "tensors" else batch.clone(False))
            samples[variant].append(
                ((time.perf_counter() - wall) / updates, (time.process_time() - cpu) / updates, (_minor_faults() - faults) / updates)
            )
    for variant, rows in samples.items():
        walls, cpus, faults = zip(*rows)
        yield {
            "variant": variant, "batch": batch_size, "s_per_update": statistics.median(walls), "min_s": min(walls),
            "cpu_s_per_update": statistics.median(cpus), "faults_per_update": statistics.median(faults),
            "warmup_s": agents[variant][3],
        }


def child(args):
    warnings.filterwarnings("ignore")
    if os.environ.get("DCS_BENCH_RETAIN_FREED_MEMORY"):
        from dcs_torchrl.modules import retain_freed_memory

        if not retain_freed_memory():
            raise SystemExit("retain_freed_memory() could not be applied")
    for batch_size in args.batch_sizes:
        for result in measure(args.variants, batch_size, args.updates, args.rounds, args.warmup, args.hidden):
            print("RESULT " + json.dumps(result), flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[512, 128])
    parser.add_argument("--updates", type=int, default=2, help="timed updates per variant and round (even)")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds; the median is reported")
    parser.add_argument("--warmup", type=int, default=2)
    parser.add_argument("--hidden", type=int, default=1024)
    parser.add_argument("--variants", nargs="+", default=SAC_VARIANTS + QTOPT_VARIANTS)
    parser.add_argument("--allocators", nargs="+", default=["glibc", "jemalloc", "glibc+retain"], choices=list(ALLOCATORS))
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.updates % 2 or args.updates < 2:
        parser.error("--updates must be even (actor and targets update every second step)")
    if args.child:
        return child(args)

    rows = []
    for allocator in args.allocators:
        if allocator == "jemalloc" and not os.path.exists(JEMALLOC):
            print(f"skipping jemalloc: {JEMALLOC} not found (apt-get install libjemalloc2)")
            continue
        env = {**os.environ, **ALLOCATORS[allocator]}
        cmd = [sys.executable, __file__, "--child", "--updates", str(args.updates), "--rounds", str(args.rounds), "--warmup", str(args.warmup),
               "--hidden", str(args.hidden), "--batch-sizes", *map(str, args.batch_sizes), "--variants", *args.variants]
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, text=True)
        for line in proc.stdout:
            if line.startswith("RESULT "):
                row = {**json.loads(line[7:]), "allocator": allocator}
                rows.append(row)
                print(f"  {allocator:13s} b={row['batch']:<4d} {row['variant']:28s} {row['s_per_update']:7.3f} s/update "
                      f"(warm-up {row['warmup_s']:.0f} s)", flush=True)
        if proc.wait():
            raise SystemExit(f"child for {allocator} failed with {proc.returncode}")

    def base(row, allocator):
        ref = "qtopt reference" if row["variant"].startswith("qtopt") else "reference"
        for r in rows:
            if r["variant"] == ref and r["batch"] == row["batch"] and r["allocator"] == allocator:
                return r["s_per_update"]
        return float("nan")

    print(f"\nmedian of {args.rounds} interleaved rounds of {args.updates} updates, after {args.warmup} warm-up updates; "
          f"torch {torch.__version__}, {torch.get_num_threads()} threads; ratios are update rates (ref s / s)")
    header = (f"{'batch':>5} {'allocator':13} {'update':28} {'s/update':>9} {'updates/s':>9} {'cpu s':>7} "
              f"{'faults':>8} {'x ref (same alloc)':>18} {'x ref glibc':>11}")
    print(header)
    print("-" * len(header))
    for row in sorted(rows, key=lambda r: (-r["batch"], r["variant"].startswith("qtopt"), r["allocator"] != "glibc", r["allocator"])):
        s = row["s_per_update"]
        print(f"{row['batch']:>5} {row['allocator']:13} {row['variant']:28} {s:9.3f} {1 / s:9.3f} "
              f"{row['cpu_s_per_update']:7.2f} {row['faults_per_update']:8.0f} "
              f"{base(row, row['allocator']) / s:18.2f} {base(row, 'glibc') / s:11.2f}")


if __name__ == "__main__":
    main()
