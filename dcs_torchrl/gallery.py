"""The paper's Figure 1: six tasks at increasing distraction difficulty; and the background blend.

    python -m dcs_torchrl.gallery --out gallery.png [--size 96] [--seed 0] [--background-dir DIR]
    python -m dcs_torchrl.gallery --blends 0 0.1 0.2 0.5 1 --out blend.png
    python -m dcs_torchrl.gallery --beyond --out lighting_textures.png

Rows are the six tasks; columns are difficulty 0, 0.1, ..., 1: camera and colour scale
in steps of 0.1, and 0, 1, 2, 4, ... background videos (doubling, capped at 60). Under them, a row
per distraction beyond the paper (docs/lighting_textures.md), alone on one task
(:data:`BEYOND_PAPER_ROWS`): the lighting at β_light and the surface textures at β_tex, each the
column's β (no videos, camera and colour as the task's).

With ``--beyond``: the figures of docs/lighting_textures.md: what each of the lighting's five numbers does at
either end of its range (β_light = 1, the others at rest), the surface textures at β_tex 0 to 1, and the
stand-in textures (training, then held out).

With ``--blends``: cartpole swingup's view at each background blend β_bg (b = 60 videos,
static), a row per seed as the paper describes the blend, and a row per seed as the 2021 code
shows it after ``--episodes`` earlier episodes of the same env (``reference_blend``).
"""
from __future__ import annotations

import argparse
import os

import cv2
import numpy as np
import torch

from dcs_torchrl import presets
from dcs_torchrl.envs import make_env

SCALES = tuple(round(0.1 * i, 1) for i in range(11))
#: The rows beyond the paper: (make_env setting set to the column's β, the row's name), on :data:`BEYOND_PAPER_TASK`.
BEYOND_PAPER_ROWS = (("light_scale", "light only"), ("texture_scale", "texture only"))
#: Their task: a floor to light and texture, and bodies that cast shadows on it.
BEYOND_PAPER_TASK = ("walker", "walk")


def num_videos(column: int) -> int:
    """Backgrounds of a column: 0, 1, then doubling up to 60."""
    return 0 if column == 0 else min(2 ** (column - 1), 60)


def cell(domain: str, task: str, column: int, size: int, seed: int, background_dir=None, steps: int = 0) -> np.ndarray:
    """One frame of ``domain``/``task`` at the difficulty of ``column``."""
    scale = SCALES[column]
    env = make_env(
        domain, task, camera_scale=scale, color_scale=scale, num_videos=num_videos(column),
        background_dir=background_dir, height=size, width=size, seed=seed,
    )
    return _frame(env, seed, steps)


def single_cell(domain: str, task: str, setting: str, column: int, size: int, seed: int, steps: int = 0) -> np.ndarray:
    """One frame of ``domain``/``task`` with make_env's ``setting`` (e.g. ``light_scale``) at the β of
    ``column`` and no other distraction (static); column 0 is :func:`cell`'s column 0."""
    env = make_env(domain, task, num_videos=0, **{setting: SCALES[column]}, height=size, width=size, seed=seed)
    return _frame(env, seed, steps)


def _frame(env, seed: int, steps: int) -> np.ndarray:
    """The frame of ``env`` after its reset and ``steps`` random actions drawn from ``seed``; closes ``env``."""
    td = env.reset()
    spec = env.action_spec
    actions = torch.Generator().manual_seed(seed)  # the random actions follow --seed too
    for _ in range(steps):
        action = spec.space.low + (spec.space.high - spec.space.low) * torch.rand(spec.shape, generator=actions)
        td = env.step(td.set("action", action.to(spec.dtype)))["next"]
    frame = td["pixels"].numpy()
    env.close()
    return frame


def _label(width: int, text: str, height: int = 18) -> np.ndarray:
    strip = np.full((height, width, 3), 255, np.uint8)
    cv2.putText(strip, text, (3, height - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA)
    return strip


def _name(words, height: int, width: int) -> np.ndarray:
    """A white cell with ``words`` one under the other, a row's name."""
    cell_ = np.full((height, width, 3), 255, np.uint8)
    for i, word in enumerate(words):
        cv2.putText(cell_, word, (3, height // 2 + 14 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA)
    return cell_


def row_names(tasks=tuple(presets.TASKS)) -> list[tuple[str, ...]]:
    """The words naming each row of :func:`gallery` under its header, top to bottom.

    Examples:
        >>> row_names([("cartpole", "swingup")])
        [('cartpole', 'swingup'), ('walker walk', 'light only'), ('walker walk', 'texture only')]
    """
    beyond = " ".join(BEYOND_PAPER_TASK)
    return [tuple(t) for t in tasks] + [(beyond, name) for _, name in BEYOND_PAPER_ROWS]


def gallery(size: int = 96, seed: int = 0, background_dir=None, steps: int = 0,
            tasks=tuple(presets.TASKS)) -> np.ndarray:
    """The whole figure as an RGB uint8 image: the header, a row per task of ``tasks`` (default: the
    paper's six), then the rows beyond the paper (:data:`BEYOND_PAPER_ROWS`), named as :func:`row_names`."""
    columns = range(len(SCALES))
    header = [_label(size, f"{SCALES[c]:.1f} / {num_videos(c)}") for c in columns]
    rows = [np.concatenate([_label(96, "beta / videos")] + header, axis=1)]
    frames = [[cell(domain, task, c, size, seed, background_dir, steps) for c in columns] for domain, task in tasks]
    frames += [[single_cell(*BEYOND_PAPER_TASK, setting, c, size, seed, steps) for c in columns]
               for setting, _ in BEYOND_PAPER_ROWS]
    for words, row in zip(row_names(tasks), frames):
        rows.append(np.concatenate([_name(words, size, 96)] + row, axis=1))
    return np.concatenate(rows, axis=0)


#: The tasks of the figure beyond the paper: a rail and a pole over the floor, bodies that shadow it, a top view.
BEYOND_TASKS = (("cartpole", "swingup"), ("walker", "walk"), ("finger", "spin"))
TEXTURE_SCALES = (0.0, 0.25, 0.5, 0.75, 1.0)


def lighting_extreme(domain: str, task: str, number: int | None, end: float, size: int, seed: int) -> np.ndarray:
    """The first frame of ``domain``/``task`` with the lighting's number ``number`` (an index of
    :data:`dcs_torchrl.distractions.lighting.AXES`; ``None``: none) at ``end`` (-1 or 1) of its range at
    β_light = 1, the other four at rest."""
    from dcs_torchrl.distractions.lighting import LightingDistraction

    env = make_env(domain, task, light_scale=1.0, height=size, width=size, seed=seed)
    env.reset()
    lighting = next(t for t in env.transform if isinstance(t, LightingDistraction))
    u = np.zeros(5)
    if number is not None:
        u[number] = end
    lighting.hold(u)
    frame = env.transform[-2]._render().numpy()  # RenderPixels, before the state keys are dropped
    env.close()
    return frame


def beyond_figure(size: int = 96, seed: int = 0) -> np.ndarray:
    """docs/lighting_textures.md's figure: per task of :data:`BEYOND_TASKS`, the lighting at either end of each
    number (:func:`lighting_extreme`), then the textures at each of :data:`TEXTURE_SCALES` (one draw per
    row: its seed)."""
    from dcs_torchrl.distractions.lighting import AXES

    ends = [(None, 0.0)] + [(i, e) for i in range(len(AXES)) for e in (-1.0, 1.0)]
    header = [_label(size, "task's" if i is None else f"{AXES[i][:6]} {e:+g}") for i, e in ends]
    rows = [np.concatenate([_label(96, "light, beta 1")] + header, axis=1)]
    for domain, task in BEYOND_TASKS:
        frames = [lighting_extreme(domain, task, i, e, size, seed) for i, e in ends]
        rows.append(np.concatenate([_name((domain, task), size, 96)] + frames, axis=1))
    width = rows[0].shape[1]
    header = [_label(size, f"beta_tex {b:g}") for b in TEXTURE_SCALES]
    block = [np.concatenate([_label(96, "textures")] + header, axis=1)]
    for k, (domain, task) in enumerate(BEYOND_TASKS):
        frames = []
        for b in TEXTURE_SCALES:
            env = make_env(domain, task, texture_scale=b, height=size, width=size, seed=seed + k)
            frames.append(_frame(env, seed + k, 0))
        block.append(np.concatenate([_name((domain, task), size, 96)] + frames, axis=1))
    block = np.concatenate(block, axis=0)
    pad = np.full((block.shape[0], width - block.shape[1], 3), 255, np.uint8)
    return np.concatenate(rows + [np.concatenate([block, pad], axis=1)], axis=0)


def standin_sheet(size: int = 96) -> np.ndarray:
    """The stand-in textures, the training split's in rows of 10, then the held-out ones."""
    from dcs_torchrl.textures import texture_set

    train, val = texture_set(None, "train"), texture_set(None, "val")
    cells = [train.image(i, size) for i in range(len(train))]
    rows = [np.concatenate([_name(("train",), size, 60)] + cells[i:i + 10], axis=1) for i in range(0, len(cells), 10)]
    held = [val.image(i, size) for i in range(len(val))]
    held += [np.full((size, size, 3), 255, np.uint8)] * (10 - len(held))
    rows.append(np.concatenate([_name(("val",), size, 60)] + held, axis=1))
    return np.concatenate(rows, axis=0)


def blend_view(blend: float, size: int, seed: int, background_dir=None, reference_blend: bool = False,
               episodes: int = 0, domain: str = "cartpole", task: str = "swingup") -> np.ndarray:
    """The first frame of an episode at background blend ``blend`` (b = 60, static), after
    ``episodes`` earlier episodes of the same env (which matter with ``reference_blend`` only)."""
    env = make_env(domain, task, num_videos=60, background_blend=blend, background_dir=background_dir,
                   reference_blend=reference_blend, height=size, width=size, seed=seed)
    for _ in range(episodes):  # static: an episode shows the frame its reset drew
        env.reset()
    frame = env.reset()["pixels"].numpy()
    env.close()
    return frame


def blend_figure(blends, size: int = 168, seeds=(0, 1), background_dir=None, episodes: int = 20) -> np.ndarray:
    """Rows: per seed, the paper's blend and the 2021 code's after ``episodes`` episodes."""
    header = [_label(size, f"blend {b:g}") for b in blends]
    rows = [np.concatenate([_label(150, "")] + header, axis=1)]
    for reference in (False, True):
        for seed in seeds:
            frames = [blend_view(b, size, seed, background_dir, reference, episodes if reference else 0) for b in blends]
            words = ([f"2021 code, seed {seed}", f"after {episodes} episodes"] if reference
                     else [f"paper, seed {seed}"])
            rows.append(np.concatenate([_name(words, size, 150)] + frames, axis=1))
    return np.concatenate(rows, axis=0)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description="Write the paper's Figure 1 for this suite, with a row each for "
                                                 "lighting and textures (beyond the paper) under its tasks.")
    parser.add_argument("--out", default="gallery.png", help="PNG file to write (refuses to overwrite without --force)")
    parser.add_argument("--size", type=int, default=96, help="side of each frame in pixels")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=10, help="random actions before each snapshot")
    parser.add_argument("--background-dir", default=None, help="DAVIS JPEGImages/480p folder (default: embedded videos)")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--blends", nargs="+", type=float, default=None, metavar="BETA",
                        help="instead: cartpole's view at these background blends, the paper's and the 2021 code's")
    parser.add_argument("--episodes", type=int, default=20, help="with --blends: earlier episodes of the 2021 code's env")
    parser.add_argument("--beyond", action="store_true",
                        help="instead: the lighting's ranges and the textures (docs/lighting_textures.md); writes --out "
                             "and, beside it, <out>_standins.png, the stand-in textures")
    args = parser.parse_args(argv)
    if os.path.exists(args.out) and not args.force:
        parser.error(f"{args.out} exists; pass --force to overwrite it or choose another --out")
    if args.beyond:
        sheet = os.path.splitext(args.out)[0] + "_standins.png"
        if os.path.exists(sheet) and not args.force:
            parser.error(f"{sheet} exists; pass --force to overwrite it or choose another --out")
        if not cv2.imwrite(sheet, standin_sheet(args.size)[..., ::-1]):
            parser.error(f"could not write {sheet}")
        print(f"wrote {sheet}")
        image = beyond_figure(args.size, args.seed)
    elif args.blends is not None:
        image = blend_figure(args.blends, 2 * args.size, (args.seed, args.seed + 1), args.background_dir, args.episodes)
    else:
        image = gallery(args.size, args.seed, args.background_dir, args.steps)
    if not cv2.imwrite(args.out, image[..., ::-1]):
        parser.error(f"could not write {args.out}")
    print(f"wrote {args.out} ({image.shape[1]}x{image.shape[0]})")


if __name__ == "__main__":
    main()
