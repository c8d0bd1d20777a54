"""The control steps of many worlds in one compiled call that holds no GIL: MuJoCo's C step functions called on
each world's own ``MjData`` by its address, with no Python per world.

:func:`step_worlds` runs, for each world of a list, what :class:`~dcs_torchrl.vector.batch_physics.BatchPhysics`
stands in for dm_control's ``Environment.step`` with: the action into ``data.ctrl``, then per control step
dm_control's legacy ``Physics.step`` (``mj_step2``, ``mj_step`` for the other substeps, ``mj_step1``; RK4:
``mj_step`` for every substep, ``mj_step1``), the task's fields copied out of the data into the record, and
dm_control's check that no warning count grew (a world whose count grew stops there, as dm_control's
``PhysicsError`` stops its env). The worlds' data are stepped in place, so everything MuJoCo keeps between steps
(the solver's warmstart, the derived fields) carries on as under dm_control. Compiled by numba (``nogil``,
cached on disk): MuJoCo's C functions are reached by name, their addresses those of the ``mujoco`` wheel's
library (:func:`dcs_torchrl._compat.private_api.mujoco_c_api`); every other address (a world's ``mjModel`` and
``mjData``, its arrays) comes in as an integer argument (:mod:`dcs_torchrl._compat.pointers`), so nothing of
one process or one MuJoCo build is compiled in.
"""
from __future__ import annotations

import llvmlite.binding
import numpy as np
from numba import carray, njit, types

from dcs_torchrl._compat.pointers import float64_at, int32_at, void_at
from dcs_torchrl._compat.private_api import mujoco_c_api

__all__ = ["step_worlds"]

# MuJoCo's step functions under names of this module's own, bound to the wheel's library at import
for _name, _address in mujoco_c_api().functions.items():
    llvmlite.binding.add_symbol(f"dcs_torchrl_{_name}", _address)
_STEP = types.void(types.voidptr, types.voidptr)  # void mj_step(const mjModel* m, mjData* d)
_mj_step = types.ExternalFunction("dcs_torchrl_mj_step", _STEP)
_mj_step1 = types.ExternalFunction("dcs_torchrl_mj_step1", _STEP)
_mj_step2 = types.ExternalFunction("dcs_torchrl_mj_step2", _STEP)


@njit(nogil=True, cache=True)
def step_worlds(worlds, actions, steps, structs, controls, sources, warnings, sub_steps, rk4, offsets, record,
                first_row, stopped, grown):
    """Steps each world ``worlds[w]`` ``steps[w]`` control steps from ``actions[w]``, in order, holding no GIL.

    Per world ``i`` (rows of the per-world tables): ``structs[i]`` its ``(mjModel*, mjData*)``, ``controls[i]``
    the address of its ``ctrl``, ``sources[i, f]`` of its field ``f``, ``warnings[i]`` of its warning counts
    (``warnings[i, 1]`` of them, ``warnings[i, 2]`` int32 apart), ``sub_steps[i]`` and ``rk4[i]`` its physics
    steps per control step and integrator. Field ``f`` is ``offsets[f + 1] - offsets[f]`` float64, recorded
    after control step ``j`` into ``record[j, first_row + w, offsets[f]:offsets[f + 1]]``. A world whose
    warning counts grew in control step ``j`` stops after it: ``stopped[w] = j + 1`` and ``grown[w, k]`` for
    each count ``k`` that grew (both left as they were for the others).
    """
    nu = actions.shape[1]
    for w in range(len(worlds)):
        i = worlds[w]
        model, data = void_at(structs[i, 0]), void_at(structs[i, 1])
        ctrl = carray(float64_at(controls[i]), nu)
        for a in range(nu):  # the task's before_step: physics.set_control(action)
            ctrl[a] = actions[w, a]
        counts = carray(int32_at(warnings[i, 0]), warnings[i, 1] * warnings[i, 2])
        before = np.empty(warnings[i, 1], np.int32)
        for k in range(len(before)):
            before[k] = counts[k * warnings[i, 2]]
        for j in range(steps[w]):
            if rk4[i]:  # dm_control's Physics.step, legacy_step
                for _ in range(sub_steps[i]):
                    _mj_step(model, data)
            else:
                _mj_step2(model, data)
                for _ in range(sub_steps[i] - 1):
                    _mj_step(model, data)
            _mj_step1(model, data)
            row = record[j, first_row + w]
            for f in range(len(offsets) - 1):
                source = carray(float64_at(sources[i, f]), offsets[f + 1] - offsets[f])
                row[offsets[f]: offsets[f + 1]] = source
            grew = False
            for k in range(len(before)):
                if counts[k * warnings[i, 2]] > before[k]:
                    grown[w, k] = grew = True
            if grew:  # dm_control's check_invalid_state: PhysicsError after this control step
                stopped[w] = j + 1
                break
