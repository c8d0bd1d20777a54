"""What each distraction of the medium dynamic benchmark adds to an agent step (default profile).

    python benchmarks/distraction_cost.py cheetah run [--steps 150] [--rounds 5] [--upload-steps 500] [--texture-size 128] [--only "medium static" ...]

The medium dynamic env against the undistracted one, and against the same env with only one
distraction switched on (the others at scale 0), stepped in interleaved rounds like
``env_speed.py``; per-step cost in ms and relative to the undistracted env. "medium dynamic,
whole sky" is the same env uploading all six sky faces whole at every new frame (what the suite
did before it sent only the part of the sky the camera sees; same pixels). Then the two medium
dynamic envs step ``--upload-steps`` more steps, interleaved in chunks, with the time spent in
the suite's own work measured around it: the distractions' per-step edits, and the sky upload (the
render context's ``upload_cube`` + ``upload_visible``); the undistracted and the medium static env
step with them, and in every env the render itself is clocked too (dm_control's
``Camera.render``: scene update, ``mjr_render``, ``mjr_readPixels``), so that the difference to
the undistracted step splits into the suite's work and the render of another scene (a moved
camera sees more or less of the reflective floor). ``--texture-size N`` adds the medium dynamic env
with an N-texel sky (the suite's default is 256) to the timed rounds, and compares its pixels with the
default's over a few seeded episodes: what a coarser sky would buy, and what it changes.
"""
from __future__ import annotations

import argparse
import os
import random
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import torch  # noqa: E402
from env_speed import interleaved_rounds, time_steps  # noqa: E402  (benchmarks/ is the script's directory)

import dcs_torchrl as dcs  # noqa: E402
from dcs_torchrl._scene import locate  # noqa: E402
from dcs_torchrl.distractions.base import DistractionTransform  # noqa: E402
from dcs_torchrl.render import gl as render  # noqa: E402

OFF = dict(camera_scale=0.0, color_scale=0.0, num_videos=0)
WHOLE_SKY = "medium dynamic, whole sky"


def coarse_sky(size: int) -> str:
    return f"medium dynamic, {size}-texel sky"


def variants(domain: str, task: str, texture_size: int | None = None) -> dict:
    medium = dict(benchmark="medium", seed=0)
    only = lambda key, dynamic: {**OFF, key: None, "dynamic": dynamic}  # None: the benchmark's value
    coarse = {} if texture_size is None else {
        coarse_sky(texture_size): lambda: dcs.make_env(domain, task, **medium, dynamic=True, texture_size=texture_size)
    }
    return {
        "none": lambda: dcs.make_env(domain, task, seed=0),
        "camera only, static": lambda: dcs.make_env(domain, task, **medium, **only("camera_scale", False)),
        "camera only, dynamic": lambda: dcs.make_env(domain, task, **medium, **only("camera_scale", True)),
        "colour only, dynamic": lambda: dcs.make_env(domain, task, **medium, **only("color_scale", True)),
        "background only, static": lambda: dcs.make_env(domain, task, **medium, **only("num_videos", False)),
        "background only, dynamic": lambda: dcs.make_env(domain, task, **medium, **only("num_videos", True)),
        "medium static": lambda: dcs.make_env(domain, task, **medium, dynamic=False),
        "medium dynamic": lambda: dcs.make_env(domain, task, **medium, dynamic=True),
        WHOLE_SKY: lambda: dcs.make_env(domain, task, **medium, dynamic=True),
        **coarse,
    }


def pixel_difference(envs: list, seeds: range, steps: int) -> tuple[float, int]:
    """Mean and max absolute difference (grey levels) between the pixels of two envs that differ only
    in rendering, over ``steps`` zero-action steps after ``set_seed(s)`` and a reset, for each seed."""
    action = torch.zeros(envs[0].action_spec.shape, dtype=envs[0].action_spec.dtype)
    total, count, worst = 0.0, 0, 0
    for seed in seeds:
        for env in envs:
            env.set_seed(seed)
        tds = [env.reset() for env in envs]
        for step in range(steps + 1):
            diff = (tds[0]["pixels"].int() - tds[1]["pixels"].int()).abs()
            total, count, worst = total + float(diff.sum()), count + diff.numel(), max(worst, int(diff.max()))
            if step < steps:
                tds = [env.step(td.set("action", action))["next"] for env, td in zip(envs, tds)]
    return total / count, worst


def quartiles(values: list[float]) -> str:
    """The first and third quartiles of ``values``, as ``"q1-q3"``."""
    if len(values) < 2:
        return f"{values[0]:.3f}-{values[0]:.3f}"
    q1, _, q3 = statistics.quantiles(values, n=4, method="inclusive")
    return f"{q1:.3f}-{q3:.3f}"


def median_interval(values: list[float], resamples: int = 2000, seed: int = 0) -> tuple[float, float]:
    """A 95% bootstrap interval of the median of ``values`` (percentiles of resampled medians)."""
    rng = random.Random(seed)
    medians = sorted(statistics.median(rng.choices(values, k=len(values))) for _ in range(resamples))
    return medians[int(0.025 * resamples)], medians[int(0.975 * resamples) - 1]


def renderer_of(env) -> render.RenderPixels:
    """The RenderPixels of a suite env."""
    return next(t for t in env.transform if isinstance(t, render.RenderPixels))


def context_of(env) -> render._Context:
    """The render context of a suite env (after its first reset)."""
    return render._CONTEXTS[locate(renderer_of(env), strict=True).physics]


class Clock:
    """Accumulates the wall time spent in the given methods of some objects (patched on the instances)."""

    def __init__(self, methods: list[tuple[object, str]]):
        self.seconds = 0.0
        for owner, name in methods:
            method = getattr(owner, name)

            def timed(*args, _method=method, **kwargs):
                start = time.perf_counter()
                result = _method(*args, **kwargs)
                self.seconds += time.perf_counter() - start
                return result

            setattr(owner, name, timed)


def suite_clocks(env) -> dict[str, Clock]:
    """Clocks on the suite's own per-step work (the distractions' edits, the sky upload) and on the render."""
    context = context_of(env)
    distractions = [t for t in env.transform if isinstance(t, DistractionTransform)]
    renderer = renderer_of(env)
    return {"distractions": Clock([(t, "_step") for t in distractions]),
            "upload": Clock([(context, "upload_cube"), (context, "upload_visible")]),
            "render": Clock([(renderer.__dict__["_camera"], "render")])}


def suite_cost(envs: dict, steps: int, chunk: int = 50) -> dict:
    """Median over chunks of the seconds per step in each clock, envs stepped in interleaved chunks."""
    clocks = {name: suite_clocks(env) for name, env in envs.items()}
    tds = {name: env.reset() for name, env in envs.items()}
    per_step = {(name, part): [] for name in envs for part in ["step", *clocks[name]]}
    for _ in range(max(1, steps // chunk)):
        for name, env in envs.items():
            before = {part: clock.seconds for part, clock in clocks[name].items()}
            seconds, tds[name] = time_steps(env, tds[name], chunk)
            per_step[name, "step"].append(seconds / chunk)
            for part, clock in clocks[name].items():
                per_step[name, part].append((clock.seconds - before[part]) / chunk)
    return {key: statistics.median(v) for key, v in per_step.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("domain")
    parser.add_argument("task")
    parser.add_argument("--steps", type=int, default=150)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--upload-steps", type=int, default=500)
    parser.add_argument("--texture-size", type=int, default=None,
                        help="also time the medium dynamic env with a sky of this many texels a side")
    parser.add_argument("--only", nargs="+", default=None, choices=list(variants("cheetah", "run")),
                        help="time only these envs (the undistracted and the medium dynamic env always): more "
                             "rounds in the same time, for a tighter ratio")
    args = parser.parse_args()
    if args.texture_size is not None and args.texture_size < 1:
        parser.error(f"--texture-size must be a positive number of texels, got {args.texture_size}")
    torch.set_num_threads(1)
    makers = variants(args.domain, args.task, args.texture_size)
    if args.only is not None:
        keep = {"none", "medium dynamic", *args.only, *([] if args.texture_size is None else [coarse_sky(args.texture_size)])}
        makers = {name: make for name, make in makers.items() if name in keep}
    envs = {name: make() for name, make in makers.items()}
    if WHOLE_SKY in envs:
        envs[WHOLE_SKY].reset()
        context_of(envs[WHOLE_SKY]).upload_all_faces = True  # the reference path, this env only
    rounds, _ = interleaved_rounds(envs, args.steps, args.rounds, resets=1)
    step = {name: statistics.median(seconds) for name, seconds in rounds.items()}
    print(f"{args.domain} {args.task}, default profile, median of {args.rounds} rounds x {args.steps} steps")
    print("| env | ms/step | vs none |")
    print("|---|---:|---:|")
    for name in envs:
        print(f"| {name} | {1e3 * step[name]:.2f} | {100 * (step[name] / step['none'] - 1):+.1f}% |")
    print(f"\nmedium dynamic / none: {step['medium dynamic'] / step['none']:.3f} per agent step (medians)")
    pairs = [(name, "none") for name in envs if name != "none"]
    if "medium static" in envs:  # the suite's per-step work alone: the same camera ranges on both sides
        pairs.append(("medium dynamic", "medium static"))
    for name, base in pairs:  # each round's own ratio: slow drifts of the machine cancel
        ratios = sorted(a / b for a, b in zip(rounds[name], rounds[base]))
        low, high = median_interval(ratios)
        print(f"{name} / {base}, round by round: median {statistics.median(ratios):.3f} (95% interval "
              f"{low:.3f}-{high:.3f}), middle half {quartiles(ratios)}, range {ratios[0]:.3f}-{ratios[-1]:.3f} "
              f"({len(ratios)} rounds)")
    if args.texture_size is not None:
        coarse = coarse_sky(args.texture_size)
        seeds, steps = range(3), 100
        mean, worst = pixel_difference([envs["medium dynamic"], envs[coarse]], seeds, steps)
        print(f"{coarse} / none: {step[coarse] / step['none']:.3f} per agent step; its pixels against the "
              f"default sky's over {len(seeds)} seeded episodes of {steps} steps: mean abs difference {mean:.2f}, "
              f"max {worst} grey levels")
    if args.upload_steps > 0:
        split = tuple(n for n in ("none", "medium static", "medium dynamic", WHOLE_SKY, coarse_sky(args.texture_size))
                      if n in envs)
        cost = suite_cost({name: envs[name] for name in split}, args.upload_steps)
        print(f"\nmedian of {args.upload_steps // 50} interleaved chunks of 50 steps, ms per agent step "
              "(the suite's work and the render, and each's difference to the undistracted env's):")
        print("| env | step, vs none | distractions' edits | sky upload | suite's work, vs none | render, vs none |")
        print("|---|---:|---:|---:|---:|---:|")
        ms = lambda name, part: 1e3 * cost[name, part]
        own = {name: ms(name, "distractions") + ms(name, "upload") for name in split}
        for name in split:
            print(f"| {name} | {ms(name, 'step'):.2f}, {ms(name, 'step') - ms('none', 'step'):+.3f} | "
                  f"{ms(name, 'distractions'):.3f} | {ms(name, 'upload'):.3f} | "
                  f"{own[name]:.3f}, {own[name] - own['none']:+.3f} | "
                  f"{ms(name, 'render'):.2f}, {ms(name, 'render') - ms('none', 'render'):+.3f} |")
        extra = 1e3 * (step["medium dynamic"] - step["none"])
        print(f"\nmedium dynamic over none: {extra:+.3f} ms per step (timed above); the suite's work "
              f"{own['medium dynamic'] - own['none']:+.3f} ms = "
              f"{100 * (own['medium dynamic'] - own['none']) / (1e3 * step['none']):.1f}% of an undistracted step, "
              f"the render {ms('medium dynamic', 'render') - ms('none', 'render'):+.3f} ms"
              + (f"; sky upload {cost['medium dynamic', 'upload'] / cost[WHOLE_SKY, 'upload']:.2f}x the whole sky's"
                 if WHOLE_SKY in envs else ""))
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    main()
