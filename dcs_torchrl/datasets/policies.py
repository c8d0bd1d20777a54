"""The behaviour policies a dataset is generated with: the random policy, a trained agent, and
the mixing that makes sets of mixed quality.

``--policy random`` draws every action uniformly from the action bounds. Any other value is a
trained agent as :func:`dcs_torchrl.pretrained.load_pretrained` loads it: a shipped agent's name
(``sac_rad_cartpole_swingup``), an exported agent's directory or a finished run's directory (its
newest checkpoint that verifies). An agent acts on the recipes' observation, ``S`` stacked
channel-first frames (its run's ``pixels.frame_stack``; the first frame repeated at a reset, as
TorchRL's ``CatFrames`` does), at its own image size, which may differ from the set's: generation
then renders the agent's frames beside the set's (generation.py).

Mixed quality, as V-D4RL makes its ``medium_replay`` / ``mixed`` sets: several ``--policy``
values (episode ``k`` is acted by policy ``k mod P``: e.g. one agent at several checkpoints and
the random policy), ``--epsilon`` (each step's action replaced by a uniformly random one with that
probability) and ``--action-noise`` (Gaussian noise of that standard deviation, in units of the
action range's half-width, added to every action and clipped to the bounds).
"""
from __future__ import annotations

import os
from collections import deque
from dataclasses import dataclass

import torch
from tensordict import TensorDict
from torchrl.envs.utils import ExplorationType, set_exploration_type

__all__ = ["EXPLORATION", "BehaviourPolicy", "Mixing", "load_behaviour"]

#: ``--exploration``: how an agent picks its action (the random policy is random either way).
EXPLORATION = {"deterministic": ExplorationType.DETERMINISTIC, "random": ExplorationType.RANDOM}


@dataclass(frozen=True)
class Mixing:
    """How every policy's actions are perturbed (the same for every episode of a set)."""

    epsilon: float = 0.0
    action_noise: float = 0.0
    exploration: str = "deterministic"

    def __post_init__(self):
        if not 0.0 <= self.epsilon <= 1.0:
            raise ValueError(f"--epsilon must be a probability in [0, 1], got {self.epsilon}.")
        if self.action_noise < 0.0:
            raise ValueError(f"--action-noise must be >= 0 (a standard deviation), got {self.action_noise}.")
        if self.exploration not in EXPLORATION:
            raise ValueError(f"--exploration must be one of {sorted(EXPLORATION)}, got {self.exploration!r}.")

    def as_dict(self) -> dict:
        return {"epsilon": self.epsilon, "action_noise": self.action_noise, "exploration": self.exploration}


@dataclass
class BehaviourPolicy:
    """One policy of a set: what it is (:meth:`record`) and how it acts on raw frames.

    Attributes:
        name: as given (``random``, a shipped agent's name or a directory).
        agent: the loaded :class:`~dcs_torchrl.pretrained.Pretrained`, ``None`` for the random policy.
        checkpoint_sha256: the SHA-256 of the checkpoint loaded (``None`` for the random policy).
    """

    name: str
    agent: object = None
    checkpoint_sha256: str | None = None

    @property
    def pixels(self) -> dict | None:
        """The agent's pixel handling (``frame_stack``, ``image_size``, ``render_profile``), ``None`` for random."""
        if self.agent is None:
            return None
        from dcs_torchrl.training.envs import pixel_options

        return pixel_options(self.agent._cfg.pixels)

    def record(self) -> dict:
        """What identifies the policy in a set's metadata (a run retrained under the same name has
        another checkpoint digest)."""
        if self.agent is None:
            return {"name": "random", "kind": "random"}
        results = self.agent.results
        return {"name": self.name, "kind": "agent", "method": results["method"],
                "domain": results["domain"], "task": results["task"], "seed": results["seed"],
                "steps": results["steps"], "checkpoint_sha256": self.checkpoint_sha256,
                "frame_stack": self.pixels["frame_stack"]}

    def check_task(self, domain: str, task: str) -> None:
        """Refuses an agent of another task than the set's."""
        if self.agent is None:
            return
        results = self.agent.results
        if (results["domain"], results["task"]) != (domain, task):
            raise ValueError(f"--policy {self.name} was trained on {results['domain']} {results['task']}, the set is "
                             f"{domain} {task}: pass --domain {results['domain']} --task {results['task']}, or "
                             "another policy (random, or an agent of this task).")

    def start_episode(self, frame: torch.Tensor) -> deque | None:
        """The frame stack of a new episode whose reset frame is ``frame`` (HWC uint8, at the agent's
        image size): the frame repeated ``frame_stack`` times; ``None`` for the random policy."""
        if self.agent is None:
            return None
        depth = self.pixels["frame_stack"]
        return deque([frame.permute(2, 0, 1)] * depth, maxlen=depth)

    @staticmethod
    def observe(stack: deque | None, frame: torch.Tensor) -> None:
        """Adds the newest frame (HWC uint8) after a step to an episode's ``stack``."""
        if stack is not None:
            stack.append(frame.permute(2, 0, 1))

    def act(self, stack: deque | None, low: torch.Tensor, high: torch.Tensor, mixing: Mixing,
            generator: torch.Generator) -> torch.Tensor:
        """The action for an episode's frame ``stack``, within ``[low, high]`` (one env's action
        bounds), perturbed by ``mixing`` with ``generator``'s draws."""
        uniform = lambda: low + (high - low) * torch.rand(low.shape, generator=generator, dtype=low.dtype)  # noqa: E731
        if self.agent is None:
            return uniform()
        if mixing.epsilon > 0 and float(torch.rand((), generator=generator)) < mixing.epsilon:
            return uniform()
        with set_exploration_type(EXPLORATION[mixing.exploration]), torch.no_grad():
            td = self.agent.policy(TensorDict({"pixels": torch.cat(list(stack))}, []))
        action = td["action"].to(low.dtype)
        if mixing.action_noise > 0:
            noise = torch.randn(action.shape, generator=generator, dtype=low.dtype) * mixing.action_noise
            action = torch.minimum(torch.maximum(action + noise * (high - low) / 2, low), high)
        return action


def load_behaviour(name: str | os.PathLike) -> BehaviourPolicy:
    """``random``, or a trained agent loaded by :func:`~dcs_torchrl.pretrained.load_pretrained` (on the CPU)."""
    if str(name) == "random":
        return BehaviourPolicy("random")
    from dcs_torchrl.pretrained import checkpoint_sha256, load_pretrained

    try:
        agent = load_pretrained(name)
    except FileNotFoundError as error:
        raise FileNotFoundError(f"--policy {name}: {error} Or pass --policy random.") from None
    return BehaviourPolicy(os.fspath(name), agent, checkpoint_sha256(name))
