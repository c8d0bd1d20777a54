"""What the lighting and texture distractions add to a medium dynamic agent step, on either renderer.

    python benchmarks/new_axes_cost.py [--tasks cartpole:swingup cheetah:run] [--steps 200] [--rounds 5]
                                      [--warp-envs 64] [--backends gl warp]

Per task and backend, two envs stepped in interleaved rounds (``env_speed.py``'s): the medium dynamic
benchmark, and the same with ``light_scale=0.5`` (dynamic, as the benchmark) and ``texture_scale=0.5``;
GL is one env, Warp a batch of ``--warp-envs`` envs (per agent step of the batch, then per env). Printed: the
median seconds a step and the ratio (docs/lighting_textures.md, "Cost"). The new axes are each on at a
scale the cost does not depend on (the walk and the draws are the same work at any β > 0).
"""
from __future__ import annotations

import argparse
import os
import statistics

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from env_speed import interleaved_rounds  # noqa: E402  (benchmarks/ is the script's directory)
from machine import cpu_model  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402

NEW = dict(light_scale=0.5, texture_scale=0.5)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=["cartpole:swingup", "cheetah:run"])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--warp-envs", type=int, default=64)
    parser.add_argument("--backends", nargs="+", default=["gl", "warp"], choices=["gl", "warp"])
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    print(f"{cpu_model()}; medium dynamic, 84x84; median over {args.rounds} interleaved rounds of {args.steps} steps")
    print("| task | backend | medium dynamic, ms a step | + light + texture, ms a step | ratio |")
    print("|---|---|---:|---:|---:|")
    for spec in args.tasks:
        domain, task = spec.split(":")
        for backend in args.backends:
            batch = dict(num_envs=args.warp_envs, backend="warp") if backend == "warp" else {}
            base = dict(benchmark="medium", dynamic=True, seed=0, **batch)
            envs = {"medium": dcs.make_env(domain, task, **base), "new": dcs.make_env(domain, task, **base, **NEW)}
            per_step, _ = interleaved_rounds(envs, args.steps, args.rounds, resets=1)
            medium, new = (statistics.median(per_step[k]) for k in ("medium", "new"))
            label = f"warp, {args.warp_envs} envs" if backend == "warp" else "gl, one env"
            print(f"| {domain} {task} | {label} | {1e3 * medium:.3f} | {1e3 * new:.3f} | {new / medium:.3f} |", flush=True)
            for env in envs.values():
                env.close()


if __name__ == "__main__":
    main()
