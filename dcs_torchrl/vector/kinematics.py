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

__all__ = ["FIELDS", "Fields", "Kinematics"]

#: The ``MjData`` fields gathered.
FIELDS = ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir", "subtree_com", "xpos")


@njit(nogil=True, cache=True)
def _gather(rows, addresses, offsets, values):  # pragma: no cover (compiled)
    """``values[i, offsets[f]:offsets[f + 1]]`` = field ``f`` of world ``i`` (at ``addresses[i, f]``), each ``i`` of ``rows``."""
    for r in range(len(rows)):
        i = rows[r]
        for f in range(len(offsets) - 1):
            values[i, offsets[f]:offsets[f + 1]] = carray(float64_at(addresses[i, f]), offsets[f + 1] - offsets[f])


class Fields:
    """Float64 fields of N worlds' ``MjData`` (one model) laid side by side in a row of ``width`` numbers: where
    each world keeps each field (:attr:`addresses`, ``[N, fields]``), the columns each takes in a row
    (:attr:`offsets`), and each field's view of such rows (:meth:`views`).

    Args:
        datas (sequence of mujoco.MjData): the worlds' data, kept alive by their owners as long as the addresses are used.
        names (sequence of str): the fields.
    """

    def __init__(self, datas, names):
        self.names = tuple(names)
        self.shapes = [np.shape(getattr(datas[0], f)) for f in self.names]
        self.offsets = np.cumsum([0, *(math.prod(shape) for shape in self.shapes)]).astype(np.int64)
        self.addresses = np.array([[address(getattr(d, f), np.float64) for f in self.names] for d in datas],
                                  np.int64).reshape(len(datas), len(self.names))
        self.width = int(self.offsets[-1])

    def views(self, values: np.ndarray) -> dict[str, np.ndarray]:
        """Each field's view of ``values`` (``[..., width]``), ``[..., *shape]``."""
        lead = values.shape[:-1]
        return {f: values[..., a:b].reshape(*lead, *shape)
                for f, a, b, shape in zip(self.names, self.offsets[:-1], self.offsets[1:], self.shapes)}


class Kinematics:
    """The :data:`FIELDS` of N worlds' ``MjData`` (``mujoco.MjData``, one model) as arrays.

    Args:
        datas (sequence of mujoco.MjData): the worlds' data, kept alive by their owners as long as this is used.
    """

    def __init__(self, datas):
        self._layout = Fields(datas, FIELDS)
        self.values = np.zeros((len(datas), self._layout.width))
        #: each field's view of :attr:`values`, ``[N, *shape]``
        self.fields = self._layout.views(self.values)

    def gather(self, rows: np.ndarray) -> None:
        """Reads the worlds ``rows`` (int64) anew."""
        _gather(rows, self._layout.addresses, self._layout.offsets, self.values)

