"""What a batch's render and distractions read of each world's new state, gathered from the worlds' own
``MjData`` into whole arrays in one compiled call (numba, no GIL, no Python per world).

:data:`FIELDS` of each world (its geoms', cameras' and lights' poses, its bodies' positions and centres of
mass) are copied, float64 as MuJoCo keeps them, into rows of :attr:`Kinematics.values`; :attr:`Kinematics.fields`
views them by name, ``[N, ...]``. The worlds' arrays are read at the addresses MuJoCo allocated them at
(a world's ``MjData`` never moves them), taken once when the batch is built.
"""
from __future__ import annotations

import math

import numpy as np
from numba import carray, njit

from dcs_torchrl._compat.pointers import address, float64_at

__all__ = ["FIELDS", "Kinematics"]

#: The ``MjData`` fields gathered.
FIELDS = ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir", "subtree_com", "xpos")


@njit(nogil=True, cache=True)
def _gather(rows, addresses, offsets, values):  # pragma: no cover (compiled)
    """``values[i, offsets[f]:offsets[f + 1]]`` = field ``f`` of world ``i`` (at ``addresses[i, f]``), each ``i`` of ``rows``."""
    for r in range(len(rows)):
        i = rows[r]
        for f in range(len(offsets) - 1):
            values[i, offsets[f]:offsets[f + 1]] = carray(float64_at(addresses[i, f]), offsets[f + 1] - offsets[f])


class Kinematics:
    """The :data:`FIELDS` of N worlds' ``MjData`` (``mujoco.MjData``, one model) as arrays.

    Args:
        datas (sequence of mujoco.MjData): the worlds' data, kept alive by their owners as long as this is used.
    """

    def __init__(self, datas):
        first = datas[0]
        shapes = [np.shape(getattr(first, f)) for f in FIELDS]
        sizes = [math.prod(shape) for shape in shapes]
        self.offsets = np.cumsum([0, *sizes]).astype(np.int64)
        self.addresses = np.array([[address(getattr(d, f), np.float64) for f in FIELDS] for d in datas], np.int64)
        self.values = np.zeros((len(datas), int(self.offsets[-1])))
        #: each field's view of :attr:`values`, ``[N, *shape]``
        self.fields = {f: self.values[:, a:b].reshape(len(datas), *shape)
                       for f, a, b, shape in zip(FIELDS, self.offsets[:-1], self.offsets[1:], shapes)}

    def gather(self, rows: np.ndarray) -> None:
        """Reads the worlds ``rows`` (int64) anew."""
        _gather(rows, self.addresses, self.offsets, self.values)

