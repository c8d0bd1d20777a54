"""Distracted pixel datasets with ground truth: generated in one command, loaded as a TorchRL replay buffer.

    python -m dcs_torchrl.datasets generate --policy sac_rad_cartpole_swingup --domain cartpole --task swingup \\
        --benchmark medium --dynamic --episodes 100 --seed 0 --out data/cartpole_medium_expert

A set holds, per transition, in TorchRL's TED layout (root and ``"next"``): the action, the
reward, ``terminated`` / ``truncated`` / ``done``, the task's state (``"state"``: the
proprioceptive observation), the distractions' state (``"distractions"``: camera, colour,
background; lighting and texture where on), and the frames (uint8, each stored once; with
``--backend warp --masks`` the masks too), memory-mapped, with a ``metadata.json`` of every setting that made it. docs/datasets.md has the
layout, the commands and the sizes.

- :func:`generate`: make (resume, extend) a set; refuses one made with other settings.
- :func:`load`: the set as a TorchRL ``TensorDictReplayBuffer`` sampling frame stacks that never
  cross an episode's boundary; :func:`load_vd4rl`: the same in the layout of TorchRL's
  ``VD4RLExperienceReplay``.
- ``python -m dcs_torchrl.datasets export``: the set in V-D4RL's DreamerV2 (npz) and DrQ+BC (hdf5)
  file layouts (:mod:`~dcs_torchrl.datasets.vd4rl`), or as a Minari dataset (:mod:`~dcs_torchrl.datasets.export`).
- ``python -m dcs_torchrl.datasets bc``: the behaviour-cloning baseline (:mod:`~dcs_torchrl.datasets.bc`).
"""
from dcs_torchrl.datasets.generation import generate
from dcs_torchrl.datasets.layout import load_data
from dcs_torchrl.datasets.loading import StackFrames, load, load_vd4rl
from dcs_torchrl.datasets.policies import Mixing

__all__ = ["Mixing", "StackFrames", "generate", "load", "load_data", "load_vd4rl"]
