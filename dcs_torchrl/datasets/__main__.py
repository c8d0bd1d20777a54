"""``python -m dcs_torchrl.datasets generate | info | bc | export``: make, describe, learn from and
export distracted pixel datasets (docs/datasets.md)."""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from dcs_torchrl.envs import SCENE_OPTIONS, EnvOptions

_TYPES = {"str": str, "float": float, "int": int}
#: make_env settings with a flag of their own below (the others get one each, from EnvOptions).
_NAMED = ("benchmark", "dynamic")


def _env_flags(parser: argparse.ArgumentParser) -> None:
    """A ``--<setting>`` flag for every make_env setting (:data:`dcs_torchrl.envs.SCENE_OPTIONS`)."""
    group = parser.add_argument_group("make_env settings (default: the benchmark's / the task's)")
    group.add_argument("--benchmark", default="none", help="none, easy, medium, blind or hard (default none)")
    group.add_argument("--dynamic", action=argparse.BooleanOptionalAction, default=False,
                       help="distractions change every step (default: once per episode)")
    fields = {f.name: f.type for f in dataclasses.fields(EnvOptions)}
    for name in SCENE_OPTIONS:
        if name in _NAMED:
            continue
        kind = fields[name].split("|")[0].strip()
        flag = "--" + name.replace("_", "-")
        if kind == "bool":
            group.add_argument(flag, dest=name, action=argparse.BooleanOptionalAction, default=None)
        else:
            group.add_argument(flag, dest=name, type=_TYPES[kind], default=None)


def _generate(args) -> None:
    from dcs_torchrl.datasets.generation import generate
    from dcs_torchrl.datasets.policies import Mixing

    options = {name: getattr(args, name) for name in SCENE_OPTIONS if getattr(args, name) is not None}
    record = generate(args.out, domain=args.domain, task=args.task, episodes=args.episodes, policies=args.policy,
                      seed=args.seed, mixing=Mixing(args.epsilon, args.action_noise, args.exploration),
                      masks=args.masks, image_size=args.image_size, render_profile=args.render_profile,
                      max_steps=args.max_steps, backend=args.backend, num_envs=args.num_envs,
                      progress=not args.no_progress, **options)
    print(_summary(args.out, record))


#: A set's renderer (its ``pixels["backend"]``, GL in a set made before the Warp backend) as its summary names it.
_RENDERERS = {"gl": "GL", "warp": "Warp"}


def _summary(path, record: dict) -> str:
    returns = record["returns"] or {"mean": float("nan"), "stderr": float("nan")}
    policies = ", ".join(p["name"] for p in record["policies"])
    pixels, size = record["pixels"], record["pixels"]["image_size"]
    backend = pixels.get("backend", "gl")
    return (f"{path}: {record['episodes']} episodes, {record['transitions']} transitions, {record['frames']} frames of "
            f"{record['env']['domain']} {record['env']['task']} ({record['env']['benchmark']}, "
            f"{'dynamic' if record['env']['dynamic'] else 'static'}; {size}x{size}, {_RENDERERS.get(backend, backend)} "
            f"renderer, {'with' if pixels.get('masks') else 'no'} masks), policy {policies}: return "
            f"{returns['mean']:.1f} ± {returns['stderr']:.1f}")


def _unfinished(path, record: dict) -> str | None:
    """What an unfinished set holds and the command that resumes it (``None`` for a finished set)."""
    from dcs_torchrl.datasets.layout import pending, resume_command, stored_episodes

    asked = record.get("asked") or {}
    whole = len(stored_episodes(Path(path)))
    if not pending(Path(path)) and whole >= asked.get("episodes", 0):
        return None
    return (f"{path}: unfinished: {whole} whole episodes of the {asked.get('episodes', '?')} asked (a run was "
            f"stopped, or is running); resume it with: {resume_command(Path(path))}")


def _info(args) -> None:
    from dcs_torchrl.datasets.layout import METADATA, check_set, read_json

    check_set(Path(args.path))
    record = read_json(Path(args.path) / METADATA)
    unfinished = _unfinished(args.path, record)
    if args.json:
        print(json.dumps({k: v for k, v in record.items() if k != "episode_table"} | {"unfinished": unfinished},
                         indent=2))
    else:
        print(unfinished or _summary(args.path, record))


def _bc(args) -> None:
    from dcs_torchrl.datasets.bc import main

    main(args)


def _export(args) -> None:
    if args.format == "minari":
        from dcs_torchrl.datasets.export import export_minari

        if args.dataset_id is None or args.out is not None:
            raise ValueError("export --format minari takes --dataset-id (and --root), not --out.")
        dataset = export_minari(args.path, args.dataset_id, root=args.root)
        print(f"wrote the Minari dataset {args.dataset_id}: {dataset.total_episodes} episodes, "
              f"{dataset.total_steps} steps")
        return
    from dcs_torchrl.datasets.vd4rl import export_vd4rl

    if args.out is None or args.dataset_id is not None:
        raise ValueError(f"export --format {args.format} takes --out DIR (a new folder), not --dataset-id.")
    files = export_vd4rl(args.path, args.out, args.format)
    print(f"wrote {len(files)} episodes in V-D4RL's {args.format.removeprefix('vd4rl-')} layout to {args.out}")


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(prog="python -m dcs_torchrl.datasets", description=__doc__,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = top.add_subparsers(dest="command", required=True)

    gen = commands.add_parser("generate", help="make (or resume, or extend) a dataset")
    gen.add_argument("--policy", nargs="+", default=["random"],
                     help="random, a shipped agent's name (sac_rad_cartpole_swingup) or a run / exported agent "
                          "directory; several: episode k is acted by the (k mod P)-th")
    gen.add_argument("--domain", required=True)
    gen.add_argument("--task", required=True)
    gen.add_argument("--episodes", type=int, required=True)
    gen.add_argument("--seed", type=int, default=0)
    gen.add_argument("--out", required=True, help="the set's folder")
    gen.add_argument("--epsilon", type=float, default=0.0, help="probability of a uniformly random action per step")
    gen.add_argument("--action-noise", type=float, default=0.0,
                     help="std of Gaussian noise added to an agent's action (units of the action range's half-width)")
    gen.add_argument("--exploration", default="deterministic", choices=["deterministic", "random"],
                     help="an agent's action: its mode (default) or a sample of its distribution")
    gen.add_argument("--masks", action="store_true", help="store make_env's masks (--backend warp)")
    gen.add_argument("--backend", default="gl", choices=["gl", "warp"],
                     help="gl: one env (default); warp: --num-envs envs rendered in one batch (the same episodes)")
    gen.add_argument("--num-envs", type=int, default=None, help="--backend warp: envs of the batch (default 16)")
    gen.add_argument("--image-size", type=int, default=None,
                     help="default: the agent's, else 84; an agent acts on its own size whatever the set's")
    gen.add_argument("--render-profile", default=None, help="default: the agent's, else default")
    gen.add_argument("--max-steps", type=int, default=None, help="cut episodes after this many steps (truncated)")
    gen.add_argument("--no-progress", action="store_true", help="no progress bar")
    _env_flags(gen)
    gen.set_defaults(run=_generate)

    info = commands.add_parser("info", help="what a set holds (its metadata.json)")
    info.add_argument("path")
    info.add_argument("--json", action="store_true", help="the whole record but the episode table")
    info.set_defaults(run=_info)

    from dcs_torchrl.datasets.bc import add_arguments

    bc = commands.add_parser("bc", help="behaviour cloning on a set, scored with the suite's evaluation")
    add_arguments(bc)
    bc.set_defaults(run=_bc)

    export = commands.add_parser("export", help="write a set as a Minari dataset or in V-D4RL's layouts")
    export.add_argument("path")
    export.add_argument("--format", choices=["minari", "vd4rl-npz", "vd4rl-hdf5"], default="minari",
                        help="minari (pip install 'minari[hdf5]'); vd4rl-npz: V-D4RL's DreamerV2 files; vd4rl-hdf5: "
                             "its DrQ+BC files (pip install h5py)")
    export.add_argument("--out", default=None, help="vd4rl-*: the new folder of the files")
    export.add_argument("--dataset-id", default=None, help="minari: the id, e.g. dcs/cartpole-swingup-medium-expert-v0")
    export.add_argument("--root", default=None, help="Minari's datasets folder (default: MINARI_DATASETS_PATH or ~/.minari)")
    export.set_defaults(run=_export)
    return top


def main(argv=None) -> None:
    args = parser().parse_args(argv)
    try:
        args.run(args)
    except (ValueError, FileExistsError, FileNotFoundError, NotADirectoryError, PermissionError,
            BlockingIOError) as error:  # a user's mistake, or another run's lock: its message, no traceback
        sys.exit(f"error: {error}")
    except ModuleNotFoundError as error:  # an extra not installed: what to install
        if "pip install" not in str(error):
            raise
        sys.exit(f"error: {error}")


if __name__ == "__main__":
    main()
