"""The distractions over arrays: a batch's worlds step as one-world transforms seeded alike, with no Python per world.

Each distraction keeps its state in arrays over worlds (``CameraWorlds``, ``ColorWorlds``,
``BackgroundWorlds``); a transform on one env is the one-world case, a Warp batch steps all its worlds in
one call. Here: the noise each world draws ahead in blocks is the noise it would draw step by step, across
early episode starts; every world's distraction states equal a one-world env's with its seed, for every
preset, static and dynamic, across partial resets and episode ends; and the Python calls of a batch step
do not grow with the worlds.
"""
import functools
import sys

import numpy as np
import pytest
import torch

from dcs_torchrl.distractions.background import bounce, bounce_many
from dcs_torchrl.distractions.noise import BLOCK_STEPS, NoiseBank
from dcs_torchrl.envs import _distracted_env, resolve_settings

pytest.importorskip("mujoco_warp")


def test_a_worlds_noise_drawn_in_blocks_is_the_noise_drawn_step_by_step_across_early_starts():
    """Worlds of different frame skips, each episode started after a random number of steps (mid-block
    or not), a start drawing numbers of its own from the same generator: every number a world takes, and
    every start's draws, are those of one generator drawn step by step."""
    skips = np.array([1, 2, 3, 8, 64, 100])
    n, width = len(skips), 3
    bank = NoiseBank(n, width, skips)
    mine = [np.random.default_rng(i) for i in range(n)]
    alone = [np.random.default_rng(i) for i in range(n)]
    plan = np.random.default_rng(99)
    for row in range(n):
        bank.use(row, mine[row])
    for episode in range(6):
        for row in range(n):  # an episode start: the generator wound back, then the start's own draws
            bank.rewind(row)
            assert mine[row].uniform() == alone[row].uniform(), (episode, row)
        for _ in range(int(plan.integers(0, 3 * BLOCK_STEPS))):
            rows = np.flatnonzero(plan.random(n) < 0.7)  # a partial step: some worlds only
            start = bank.take(rows)
            for j, row in enumerate(rows):
                taken = bank.values[row, start[j]:start[j] + skips[row] * width]
                expected = alone[row].standard_normal(skips[row] * width)
                np.testing.assert_array_equal(taken, expected, err_msg=f"{episode}, world {row}")


def test_a_new_generator_drops_what_was_drawn_from_the_former():
    bank = NoiseBank(1, 4, 2)
    bank.use(0, np.random.default_rng(0))
    bank.take(np.array([0]))
    bank.use(0, np.random.default_rng(1))
    start = bank.take(np.array([0]))[0]
    np.testing.assert_array_equal(bank.values[0, start:start + 8], np.random.default_rng(1).standard_normal(8))


def test_bounce_in_closed_form_is_the_frame_by_frame_bounce():
    def stepwise(frame, direction, length, n_steps):
        if length < 2:
            return 0, direction
        for _ in range(n_steps):
            if not 0 <= frame + direction < length:
                direction = -direction
            frame += direction
        return frame, direction

    cases = [(f, d, length, k) for length in range(1, 8) for f in range(length) for d in (1, -1) for k in range(25)]
    frames, directions = bounce_many(*(np.array(c, np.int64) for c in zip(*cases)))
    for case, frame, direction in zip(cases, frames, directions):
        assert (frame, direction) == stepwise(*case) == bounce(*case), case


def _states_alone(settings, seed: int, steps: int, resets: dict) -> list[dict]:
    """Each step's distraction states of one env without a render (the one-world transforms), reset at the
    steps ``resets`` names and at each episode's end."""
    env = _distracted_env(settings, True)
    env.set_seed(seed)
    td = env.reset()
    out = [td["distractions"].clone()]
    for t in range(steps):
        td = env.step(td.set("action", env.action_spec.zero()))["next"]
        out.append(td["distractions"].clone())
        if t in resets or td["done"].item():
            td = env.reset()
            out[-1] = {"after": out[-1], "reset": td["distractions"].clone()}
    env.close()
    return out


PRESETS = [(b, d, {}) for b in ("none", "easy", "medium", "blind", "hard") for d in (False, True)]
# the two axes beyond the paper, over a preset's three
PRESETS += [("medium", d, {"light_scale": 0.6, "texture_scale": 0.5}) for d in (False, True)]
KEYS = ("camera", "color", "background", "lighting", "texture")


@pytest.mark.parametrize("benchmark, dynamic, extra", PRESETS,
                         ids=[f"{b}-{'dynamic' if d else 'static'}{'-light-texture' if e else ''}" for b, d, e in PRESETS])
def test_every_worlds_distraction_states_are_those_of_one_env_with_its_seed(benchmark, dynamic, extra):
    """Every world of a batch, every step, the camera, colour, background, lighting and texture states of one
    env seeded alike: across a partial reset in the middle of a world's noise block and an episode's end
    (walker, action repeat 2: a block is 32 agent steps; cartpole at action repeat 300: an episode is 4 agent
    steps)."""
    from dcs_torchrl.vector.batched import BatchedSuiteEnv

    for domain, task, repeat, steps, resets in (("walker", "walk", 2, 40, {0: {1}, 1: {5, 37}}),
                                                ("cartpole", "swingup", 300, 10, {})):
        settings = resolve_settings(domain, task, benchmark=benchmark, dynamic=dynamic, action_repeat=repeat,
                                    texture_size=16, **extra)
        n = 3
        env = BatchedSuiteEnv([_distracted_env(settings, True) for _ in range(n)], height=16, width=16,
                              render_chunks=2)
        seeds = [5]
        for _ in range(n - 1):
            seeds.append(_distracted_env(settings, True).set_seed(seeds[-1]))
        env.set_seed(5)
        td = env.reset()
        batched = [td["distractions"].clone()]
        zero = torch.zeros(env.action_spec.shape, dtype=env.action_spec.dtype)
        for t in range(steps):
            td = env.step(td.set("action", zero))["next"]
            batched.append(td["distractions"].clone())
            mask = torch.tensor([t in resets.get(i, ()) or bool(td["done"][i]) for i in range(n)])
            if mask.any():
                td = env.reset(td.set("_reset", mask.unsqueeze(-1)))
                batched[-1] = {"after": batched[-1], "reset": td["distractions"].clone(), "mask": mask}
        env.close()
        for i in range(n):
            alone = _states_alone(settings, seeds[i], steps, resets.get(i, set()))
            for t, (b, a) in enumerate(zip(batched, alone)):
                reset = isinstance(b, dict) and bool(b["mask"][i])
                assert reset == isinstance(a, dict), f"{domain}: world {i} reset at step {t} in one run only"
                if reset:
                    pairs = [(b["after"], a["after"]), (b["reset"], a["reset"])]
                else:  # a world not reset keeps its state through the others' reset
                    pairs = [(b["after"], a), (b["reset"], a)] if isinstance(b, dict) else [(b, a)]
                for bb, aa in pairs:
                    assert set(bb.keys()) == set(aa.keys()) <= set(KEYS)
                    for key in aa.keys():
                        assert torch.equal(bb[key][i], aa[key]), f"{domain} {benchmark}: world {i}, step {t}, {key}"


def _python_calls(n: int, steps: int = 16) -> float:
    """Python-level calls (and calls into C) on the main thread a batch step makes, per step (cartpole,
    medium dynamic, one render part: the render's calls are the same for any number of worlds)."""
    from dcs_torchrl.vector.batched import BatchedSuiteEnv

    settings = resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True, texture_size=8, light_scale=0.5,
                                texture_scale=0.5)
    env = BatchedSuiteEnv([_distracted_env(settings, True) for _ in range(n)], height=8, width=8, render_chunks=1,
                          physics_threads=1)
    env.set_seed(0)
    td = env.reset()
    action = torch.zeros(env.action_spec.shape, dtype=env.action_spec.dtype)
    for _ in range(2):  # compiled and warm
        td = env.step(td.set("action", action))["next"]
    count = 0

    def profile(frame, event, arg):
        nonlocal count
        if event in ("call", "c_call"):
            count += 1

    sys.setprofile(profile)
    try:
        for _ in range(steps):
            td = env.step(td.set("action", action))["next"]
    finally:
        sys.setprofile(None)
    env.close()
    return count / steps


def test_the_python_calls_of_a_batch_step_do_not_grow_with_the_worlds():
    """Physics, distractions and scene over arrays: at most 2 Python calls more per world a step, N = 8 to 64
    (the blocks of noise each world draws every BLOCK_STEPS control steps, its only call)."""
    few, many = _python_calls(8), _python_calls(64)
    assert (many - few) / (64 - 8) <= 2, (few, many)


def test_a_clone_of_a_distraction_leaves_the_originals_episodes_alone():
    """TorchRL clones transforms (shallow copies: ``parent`` views, new envs); a clone reseeded or reset must not
    redirect the original's walk noise: the original's states stay those of an env with no clone."""
    settings = resolve_settings("cartpole", "swingup", benchmark="medium", dynamic=True, action_repeat=2, texture_size=16,
                                light_scale=0.5, texture_scale=0.5)
    runs = []
    for cloned in (False, True):
        env = _distracted_env(settings, True)
        env.set_seed(3)
        td = env.reset()
        if cloned:
            clones = [t.clone() for t in env.transform]
            for c in clones:
                c.reseed(99)
        states = [td["distractions"].clone()]
        for _ in range(40):  # across a block of noise (32 agent steps at action repeat 2)
            td = env.step(td.set("action", env.action_spec.zero()))["next"]
            states.append(td["distractions"].clone())
        runs.append(torch.stack(states))
        env.close()
    for key in KEYS:
        assert torch.equal(runs[0][key], runs[1][key]), key
