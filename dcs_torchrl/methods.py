"""The paper's six methods, defined once: algorithm x augmentation (Stone et al. 2021, section 4).

A method is an algorithm (SAC or QT-Opt, whose agent class lives in :mod:`dcs_torchrl.algorithms`)
with an augmentation setting: none (K = M = 0), RAD (one random-shift copy, K = M = 1) or DrQ (two,
K = M = 2). The recipes (``algo.name``, ``algo.aug``), the experiment grid, the evaluator and the
report all read this registry. Pure data: importing it imports neither torch nor the agents.

>>> METHODS["QT-Opt+RAD"], METHODS["QT-Opt+RAD"].copies
(Method(name='QT-Opt+RAD', algo='qtopt', aug='rad'), 1)
>>> method_name("sac", "drq"), list(METHODS)[:3]
('SAC+DrQ', ['SAC', 'SAC+RAD', 'SAC+DrQ'])
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import MappingProxyType

__all__ = ["ALGORITHMS", "AUGMENTATIONS", "METHODS", "Method", "agent_class", "augmentation_copies", "method", "method_name"]

#: algo -> (the paper's name, the module and class of its agent).
ALGORITHMS = MappingProxyType({
    "sac": ("SAC", "dcs_torchrl.algorithms.sac", "SACAgent"),
    "qtopt": ("QT-Opt", "dcs_torchrl.algorithms.qtopt", "QTOptAgent"),
})
#: aug -> (the suffix of the paper's name, the augmented copies K = M): the one definition of K = M.
AUGMENTATIONS = MappingProxyType({"none": ("", 0), "rad": ("+RAD", 1), "drq": ("+DrQ", 2)})


def augmentation_copies(aug: str) -> int:
    """The number of augmented copies K = M of an augmentation setting (``algo.aug``).

    Args:
        aug (str): ``"none"``, ``"rad"`` or ``"drq"``.

    Examples:
        >>> augmentation_copies("drq")
        2
    """
    if aug not in AUGMENTATIONS:
        raise ValueError(f"unknown augmentation {aug!r}: choose one of {list(AUGMENTATIONS)} (algo.aug=...).")
    return AUGMENTATIONS[aug][1]


@dataclass(frozen=True)
class Method:
    """One of the paper's methods: its name, ``algo`` (recipe ``algo.name``), ``aug`` and K = M."""

    name: str
    algo: str
    aug: str

    @property
    def copies(self) -> int:
        """K = M, the augmented copies of ``aug``."""
        return augmentation_copies(self.aug)


#: The six methods by name, in the paper's row order.
METHODS = MappingProxyType({
    ALGORITHMS[algo][0] + suffix: Method(ALGORITHMS[algo][0] + suffix, algo, aug)
    for algo in ALGORITHMS for aug, (suffix, _) in AUGMENTATIONS.items()
})


def method_name(algo: str, aug: str) -> str:
    """The paper's name of ``algo`` with ``aug``, e.g. ``("qtopt", "rad")`` -> ``"QT-Opt+RAD"``."""
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}: choose one of {list(ALGORITHMS)} (algo.name=...).")
    if aug not in AUGMENTATIONS:
        raise ValueError(f"unknown augmentation {aug!r}: choose one of {list(AUGMENTATIONS)} (algo.aug=...).")
    return ALGORITHMS[algo][0] + AUGMENTATIONS[aug][0]


def method(name: str) -> Method:
    """The method called ``name`` (``"SAC+RAD"``, ...)."""
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}: choose among {', '.join(METHODS)}.")
    return METHODS[name]


def agent_class(algo: str) -> type:
    """The agent class of ``algo`` (:class:`~dcs_torchrl.algorithms.SACAgent`, ``QTOptAgent``)."""
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}: choose one of {list(ALGORITHMS)}.")
    _, module, name = ALGORITHMS[algo]
    return getattr(importlib.import_module(module), name)
