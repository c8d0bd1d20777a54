"""How far MuJoCo Warp's frames are from GL's on the same states, and what the difference is made of.

    python benchmarks/backend_fidelity.py [--steps 20] [--size 84] [--presets none medium light texture] [--out DIR]

Per task and preset (``medium``: static, so that the camera and colours of a step are the episode's),
a GL env and a one-env Warp batch with the same seed, reset, step through the same random actions: their
physics states and distraction draws are equal (``tests/test_batched.py``), so each frame pair shows
one state through two renderers. Printed: the mean absolute pixel difference (grey levels, 0-255)
of Warp's frames against GL's default profile, and against GL with one thing switched off, to show
what the difference is made of: the floor's reflection (``mjRND_REFLECTION``) and 4x multisampling
(GL's ``fast`` profile renders without it); and Warp without its shadows (its ``fast`` profile)
against GL's default. ``--out`` writes one PNG per task and preset: GL | Warp | 4x
the difference.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from distraction_cost import renderer_of  # noqa: E402  (benchmarks/ is the script's directory)
from machine import cpu_model  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402

FLAGS = mujoco.mjtRndFlag
PRESETS = {"none": dict(benchmark="none"), "medium": dict(benchmark="medium", dynamic=False),
           # the distractions beyond the paper at their widest, alone (docs/lighting_textures.md)
           "light": dict(benchmark="none", light_scale=1.0), "texture": dict(benchmark="none", texture_scale=1.0)}


def frames(env, actions, flags: dict | None = None) -> np.ndarray:
    """The frames of ``env`` after each action, from a reset; ``flags``: GL scene flags, set after the reset."""
    td = env.reset()
    if flags:
        camera = renderer_of(env).__dict__["_camera"]
        for flag, value in flags.items():
            camera._scene.flags[flag] = value
    out = []
    for action in actions:
        td = env.step(td.set("action", action.reshape(env.action_spec.shape)))["next"]
        out.append(td["pixels"].reshape(-1, *td["pixels"].shape[-3:])[0].numpy())
    env.close()
    return np.stack(out)


def mad(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.int16) - b.astype(np.int16)).mean())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--size", type=int, default=84)
    parser.add_argument("--presets", nargs="+", default=["none", "medium"], choices=list(PRESETS))
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    size = dict(height=args.size, width=args.size)
    print(f"{cpu_model()}; {args.size}x{args.size}, seed 0, {args.steps} random actions after a reset; mean absolute "
          "difference of Warp's frames to GL's, grey levels")
    print("| task | preset | GL default | GL, no reflection | GL, no MSAA (fast) | Warp without shadows |")
    print("|---|---|---:|---:|---:|---:|")
    for domain, task in sorted(dcs.TASKS):
        for preset in args.presets:
            options = dict(PRESETS[preset], seed=0, **size)
            probe = dcs.make_env(domain, task, **options)
            torch.manual_seed(0)
            actions = [probe.action_spec.rand() for _ in range(args.steps)]
            probe.close()
            gl = lambda **extra: dcs.make_env(domain, task, **options, **extra)  # noqa: E731
            warp = lambda **extra: dcs.make_env(domain, task, num_envs=1, backend="warp", **options, **extra)  # noqa: E731
            w = frames(warp(), actions)
            g = frames(gl(), actions)
            no_reflection = frames(gl(), actions, {FLAGS.mjRND_REFLECTION: 0})
            no_msaa = frames(gl(render_profile="fast"), actions)
            no_shadow = mad(frames(warp(render_profile="fast"), actions), g)
            print(f"| {domain} {task} | {preset} | {mad(w, g):.2f} | {mad(w, no_reflection):.2f} | {mad(w, no_msaa):.2f} | "
                  f"{no_shadow:.2f} |", flush=True)
            if args.out:
                import cv2

                Path(args.out).mkdir(parents=True, exist_ok=True)
                diff = np.clip(4 * np.abs(w[-1].astype(int) - g[-1].astype(int)), 0, 255).astype(np.uint8)
                image = np.concatenate([g[-1], w[-1], diff], axis=1)
                cv2.imwrite(str(Path(args.out) / f"{domain}_{preset}.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))


if __name__ == "__main__":
    main()
