"""A dataset's files: one memory-mapped TensorDict, written one whole episode at a time.

::

    <set>/metadata.json      every setting of the set, its policies, seeds, episodes, keys (metadata.py)
    <set>/data/              the set: TensorDict.load_memmap(<set>/data), batch size []
        transitions/           [N] transitions in TorchRL's TED layout, without the pixels
        frames/                [F] the frames, each once: "pixels" uint8 [F, H, W, 3] (and "masks" [F, H, W])
        episodes.json          per episode: its seed, policy, return, steps, first transition and frame
    <set>/episodes/<k>/      while generating: episode k alone, in the same layout (renamed into
                             place once written whole; merged into data/ when the run ends)

Transition ``i`` of episode ``k`` observes frame ``transitions["frame"][i]`` and reaches frame
``frame + 1``; ``transitions["first_frame"][i]`` is the frame of its episode's reset, so a stack
of ``S`` frames is ``frame - S + 1 ... frame`` clamped at ``first_frame`` (the reset frame
repeated, as TorchRL's ``CatFrames`` does) and never reaches into another episode.

Every write is atomic: an episode is written under a temporary name and renamed; the merged
``data/`` is written as ``data.tmp`` and swapped in (the previous ``data`` kept as ``data.old``
until the swap is done, and restored from it if a run died in between). One run at a time writes a
set: :func:`writing` holds an exclusive lock on its folder (``flock``), and a second writer is
refused before it writes anything.
"""
from __future__ import annotations

import json
import os
import shlex
import shutil
from contextlib import contextmanager
from pathlib import Path

from tensordict import TensorDict

from dcs_torchrl.training.rundir import write_json_atomic as write_json

__all__ = ["DATA", "EPISODES", "METADATA", "SetBusyError", "check_folder", "check_set", "episode_table", "load_data",
           "merge_episodes", "pending", "read_json", "recover", "resume_command", "stored_episodes", "write_episode",
           "write_json", "writing"]

METADATA = "metadata.json"
DATA = "data"
EPISODES = "episodes"
_TABLE = "episodes.json"
#: Per-transition entries counted in frames, shifted by the episode's first frame when merged.
FRAME_KEYS = ("frame", "first_frame")


class SetBusyError(BlockingIOError):
    """Another run is writing the set (it holds the set's lock)."""


def read_json(path: Path):
    return json.loads(Path(path).read_text())


def check_folder(out: Path, flag: str = "--out", wanted: str = "a new folder's path (or a set's folder)") -> None:
    """Refuses ``out`` naming something that is not a folder; the message asks for ``wanted``."""
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"{flag} {os.fspath(out)} is a file, not a folder: give {wanted}.")


def check_set(out: Path) -> None:
    """Refuses ``out`` holding no set (a file, or a folder without ``metadata.json``), naming the command
    that makes one."""
    check_folder(out, "the set", "a set's folder")
    if not (out / METADATA).is_file():
        raise FileNotFoundError(f"{os.fspath(out)} holds no dataset ({os.fspath(out / METADATA)} is missing): make "
                                f"one with: {resume_command(out)}")


def resume_command(out: Path) -> str:
    """The ``generate`` command that makes the set ``out`` and resumes it: the one its ``metadata.json``
    records, else the command's shape."""
    meta = Path(out) / METADATA
    asked = (read_json(meta).get("asked") or {}) if meta.is_file() else {}
    return asked.get("command") or f"python -m dcs_torchrl.datasets generate ... --out {shlex.quote(os.fspath(out))}"


@contextmanager
def writing(out: Path):
    """Holds the exclusive lock of the set ``out`` (an existing folder) while a run writes it: a
    second writer is refused (:class:`SetBusyError`) before it writes anything. The lock is the
    kernel's (``flock`` on the folder), so a killed run leaves none behind."""
    import fcntl

    fd = os.open(out, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SetBusyError(f"{os.fspath(out)} is being written by another generate run (it holds the set's lock): "
                               "wait for that run to end, then run this command again (it resumes the set, or "
                               "finds nothing left to do).") from None
        yield
    finally:
        os.close(fd)


def pending(out: Path) -> bool:
    """Whether a run left something to finish: written episodes not merged, a merge or a swap."""
    return (out / EPISODES).is_dir() or (out / f"{DATA}.old").exists() or (out / f"{DATA}.tmp").exists()


def recover(out: Path) -> None:
    """Finishes or undoes what a killed run left half done: a temporary episode or merge, a swap."""
    data, old, tmp = out / DATA, out / f"{DATA}.old", out / f"{DATA}.tmp"
    if old.exists():
        if data.exists():
            shutil.rmtree(old)
        else:
            old.rename(data)
    if tmp.exists():
        shutil.rmtree(tmp)
    for leftover in (out / EPISODES).glob(".*.tmp-*"):
        shutil.rmtree(leftover)


def episode_table(out: Path) -> list[dict]:
    """The episodes merged into ``data/`` (``[]`` before the first merge)."""
    table = out / DATA / _TABLE
    return read_json(table) if table.is_file() else []


def stored_episodes(out: Path) -> dict[int, dict]:
    """Every complete episode, merged or not: index -> its summary."""
    done = {e["episode"]: e for e in episode_table(out)}
    for chunk in sorted((out / EPISODES).glob("[0-9]*")):
        summary = read_json(chunk / _TABLE)
        done.setdefault(summary["episode"], summary)
    return done


def write_episode(out: Path, episode: int, transitions: TensorDict, frames: TensorDict, summary: dict) -> None:
    """Writes one whole episode (``transitions`` [T], ``frames`` [T + 1], frame ids counted from 0)."""
    folder = out / EPISODES
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / f".{episode:06d}.tmp-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    TensorDict({"transitions": transitions, "frames": frames}, []).memmap(tmp)
    write_json(tmp / _TABLE, {"episode": episode, **summary})  # inside the folder: renamed with it
    os.rename(tmp, folder / f"{episode:06d}")


def _sources(out: Path, episodes: int) -> list[tuple[dict, TensorDict, int, int]]:
    """Per episode ``0 .. episodes - 1`` in order: its summary, the TensorDict holding it, and where
    it starts there (transition, frame)."""
    merged = {e["episode"]: e for e in episode_table(out)}
    data = load_data(out) if merged else None
    sources = []
    for k in range(episodes):
        if k in merged:
            e = merged[k]
            sources.append((e, data, e["first_transition"], e["first_frame"]))
        else:
            chunk = out / EPISODES / f"{k:06d}"
            if not chunk.is_dir():
                raise FileNotFoundError(f"{out}: episode {k} is missing; run generate again to write it.")
            sources.append((read_json(chunk / _TABLE), _memmap(chunk), 0, 0))
    return sources


def merge_episodes(out: Path, episodes: int) -> list[dict]:
    """Merges episodes ``0 .. episodes - 1`` (those in ``data/`` and the written ones) into one
    ``data/``, swapped in atomically; the merged episodes' folders are removed. Returns the table."""
    if len(episode_table(out)) >= episodes:
        return episode_table(out)  # nothing new
    sources = _sources(out, episodes)
    lengths = [e["steps"] for e, *_ in sources]
    first = sources[0][1]
    transitions, frames = sum(lengths), sum(lengths) + len(lengths)
    template = TensorDict({"transitions": first["transitions"][0].expand(transitions),
                           "frames": first["frames"][0].expand(frames)}, [])
    tmp = out / f"{DATA}.tmp"
    merged = template.memmap_like(tmp)
    table, t0, f0 = [], 0, 0
    for (summary, td, i, f), steps in zip(sources, lengths):
        rows = td["transitions"][i:i + steps].to_tensordict()
        for key in FRAME_KEYS:
            rows[key] = rows[key] - f + f0
        merged["transitions"][t0:t0 + steps] = rows
        merged["frames"][f0:f0 + steps + 1] = td["frames"][f:f + steps + 1]
        table.append({**summary, "first_transition": t0, "first_frame": f0})
        t0, f0 = t0 + steps, f0 + steps + 1
    write_json(tmp / _TABLE, table)
    del merged, sources, first
    data, old = out / DATA, out / f"{DATA}.old"
    if data.exists():
        data.rename(old)
    tmp.rename(data)
    if old.exists():
        shutil.rmtree(old)
    for k in range(episodes):
        chunk = out / EPISODES / f"{k:06d}"
        if chunk.exists():
            shutil.rmtree(chunk)
    if (out / EPISODES).is_dir() and not any((out / EPISODES).iterdir()):
        (out / EPISODES).rmdir()
    return table


def load_data(out: Path) -> TensorDict:
    """The merged set, memory-mapped (nothing read until indexed); a folder holding none is refused with
    the command that makes it (or resumes it: :func:`resume_command`)."""
    out = Path(out)
    table = out / DATA / _TABLE
    if not table.is_file():
        check_set(out)
        raise FileNotFoundError(f"{os.fspath(out)} is an unfinished dataset ({os.fspath(table)} is missing: a generate "
                                f"run was stopped, or is running); resume it with: {resume_command(out)}")
    return _memmap(out / DATA)


def _memmap(folder: Path) -> TensorDict:
    """The memory-mapped TensorDict in ``folder``, refused if it holds pickled Python objects (a set this suite
    writes holds tensors only; unpickling a folder someone hands over could run code)."""
    try:
        return TensorDict.load_memmap(folder, allow_pickle=False)
    except RuntimeError as error:
        if "pickle" not in str(error).lower():
            raise
        raise ValueError(f"{os.fspath(folder)} holds pickled Python objects, which a dataset of this suite never "
                         "does: it was not loaded, as unpickling it could run code.") from None
