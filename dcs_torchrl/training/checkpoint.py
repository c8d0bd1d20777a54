"""Checkpoints that survive SIGKILL: atomic writes, a checksum, fall back to the previous one.

Each checkpoint is ``checkpoint_<frames>.pt`` plus ``checkpoint_<frames>.pt.sha256``. The data is
written to a temporary file, flushed to disk and renamed (a killed write leaves only a ``.tmp``
file, never a half-written checkpoint under the final name); the checksum file is written the
same way afterwards, so a checkpoint without a matching checksum is incomplete or corrupt.
:func:`load_latest` verifies the newest checkpoint and falls back to older ones, warning about
each one it skips. The newest ``keep`` checkpoints are kept.

Checkpoints load with ``torch.load(..., weights_only=True)``: tensors, numbers, strings and
containers of them, nothing that unpickling could run. A checkpoint that holds more (a file the
suite did not write, or one written before RNG states were stored as tensors) is refused with an
:class:`UntrustedCheckpointError` naming what it holds; ``trust=True`` loads it as any pickle (its
checksum file proves the bytes are intact, not who wrote them).
"""
from __future__ import annotations

import hashlib
import os
import pickle
import re
import warnings
from pathlib import Path

import torch

__all__ = ["CheckpointError", "UntrustedCheckpointError", "list_checkpoints", "load_latest", "save_checkpoint"]

_NAME = re.compile(r"^checkpoint_(\d+)\.pt$")


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be used (corrupt, incomplete, or from another config)."""


class UntrustedCheckpointError(CheckpointError):
    """A checkpoint that holds more than ``torch.load(..., weights_only=True)`` reads: unpickling it
    could run code. Refused unless its source is trusted (``trust=True``)."""


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 22), b""):
            digest.update(block)
    return digest.hexdigest()


def _atomic_write(path: Path, write) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def list_checkpoints(directory: str | os.PathLike) -> list[tuple[int, Path]]:
    """``(frames, path)`` of the checkpoint files in ``directory``, oldest first."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in directory.iterdir() if (m := _NAME.match(p.name))]
    return sorted(found)


def save_checkpoint(directory: str | os.PathLike, frames: int, state: dict, *, keep: int = 2) -> Path:
    """Writes ``state`` as the checkpoint at ``frames`` and deletes all but the newest ``keep``."""
    if keep < 1:
        raise ValueError(f"keep must be >= 1, got {keep}.")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"checkpoint_{frames:012d}.pt"
    _atomic_write(path, lambda f: torch.save(state, f))
    checksum = _sha256(path)
    _atomic_write(path.with_name(path.name + ".sha256"), lambda f: f.write(checksum.encode()))
    for _, old in list_checkpoints(directory)[:-keep]:
        old.unlink(missing_ok=True)
        old.with_name(old.name + ".sha256").unlink(missing_ok=True)
    return path


def _untrusted(path: Path, err: pickle.UnpicklingError) -> UntrustedCheckpointError:
    """The refusal of ``path``, naming the Python objects it holds beyond weights_only's."""
    try:
        held = ", ".join(torch.serialization.get_unsafe_globals_in_checkpoint(path))
    except Exception:  # noqa: BLE001 - the listing is for the message only; torch's own reason follows
        held = ""
    reason = held or next((line for line in str(err).splitlines() if "unsupported" in line.lower()), str(err))
    return UntrustedCheckpointError(
        f"{path} holds Python objects beyond tensors, numbers and strings ({reason}): unpickling it could run code, "
        "so it was not loaded (its .sha256 file proves the bytes are intact, not who wrote them). If you trust its "
        "source, load it with trust_checkpoint=True (python -m dcs_torchrl.robustness --trust-checkpoint; the "
        "recipes' resume and evaluate.py: checkpoint.trust=true).")


def _load_verified(path: Path, trust: bool = False) -> dict:
    sidecar = path.with_name(path.name + ".sha256")
    if not sidecar.exists():
        raise CheckpointError(f"{path} has no checksum file (its write did not finish).")
    if sidecar.read_text().strip() != _sha256(path):
        raise CheckpointError(f"{path} does not match its checksum (corrupt).")
    try:
        return torch.load(path, map_location="cpu", weights_only=not trust)
    except pickle.UnpicklingError as err:
        if not trust:  # weights_only refused an object: nothing of it ran
            raise _untrusted(path, err) from None
        raise CheckpointError(f"{path} cannot be read: {err}") from err
    except Exception as err:  # noqa: BLE001 - any other unpickling failure means the file is unusable
        raise CheckpointError(f"{path} cannot be read: {err}") from err


def load_latest(directory: str | os.PathLike, *, trust: bool = False) -> tuple[int, dict] | None:
    """The newest checkpoint that verifies, as ``(frames, state)``; ``None`` if there is none.

    Checkpoints that fail verification are skipped with a warning (and left on disk for
    inspection); older ones are tried in turn. One that verifies but holds more than
    ``weights_only=True`` reads raises :class:`UntrustedCheckpointError` (an older one is not
    taken in its place); ``trust=True`` loads it as any pickle: only for files of a trusted source.
    """
    for frames, path in reversed(list_checkpoints(directory)):
        try:
            return frames, _load_verified(path, trust)
        except UntrustedCheckpointError:
            raise
        except CheckpointError as err:
            warnings.warn(f"skipping checkpoint: {err} Trying the previous one.", stacklevel=2)
    return None
