"""ColorDistraction: random colours for every material of the scene (Stone et al. 2021, Sec. 3.2)."""
from __future__ import annotations

import numpy as np
from numba import njit

from dcs_torchrl._scene import Scene, originals
from dcs_torchrl.distractions.base import DistractionTransform, check_scale, per_world
from dcs_torchrl.distractions.noise import NoiseBank

_WALK_STD = 0.03  # σ of the dynamic random walk per step, times β (the paper's Sec. 3.2)


class ColorDistraction(DistractionTransform):
    """Shifts the RGB of every MuJoCo material, static or dynamic (Stone et al. 2021, Sec. 3.2; docs/paper.md).

    At each reset every channel x of every material (``model.mat_rgba``) is drawn from
    U(x₀ - β, x₀ + β) ∩ [0, 1] around its original value x₀. In the dynamic setting it
    then moves by N(0, 0.03·β) per control step (``frame_skip`` steps per agent step),
    clipped to stay within β of x₀ and within [0, 1]. Alpha is never touched.

    Args:
        scale (float): β_rgb in [0, 1]. 0 leaves the colours untouched.
        dynamic (bool): change the colours at every control step. Defaults to ``False``.

    Keyword Args:
        seed (int, optional), expose (bool): see :class:`DistractionTransform`; the
            exposed state is the current RGB, float [n_materials, 3].

    Examples:
        >>> from torchrl.envs import DMControlEnv, TransformedEnv, Compose
        >>> from dcs_torchrl import ColorDistraction, RenderPixels
        >>> env = TransformedEnv(
        ...     DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=8),
        ...     Compose(ColorDistraction(0.3, dynamic=True, seed=0, expose=True), RenderPixels()),
        ... )
        >>> env.rollout(2)["next", "distractions", "color"].shape
        torch.Size([2, 13, 3])
    """

    state_name = "color"
    seed_tag = 2

    def __init__(self, scale: float, dynamic: bool = False, *, seed: int | None = None, expose: bool = False):
        self.scale = check_scale("ColorDistraction scale", scale)
        self.dynamic = bool(dynamic)
        super().__init__(seed=seed, expose=expose)

    def _on_bind(self, scene: Scene) -> None:
        self._original = originals(scene.physics).mat_rgba[:, :3].astype(np.float64)

    def _new_worlds(self, scene: Scene) -> "ColorWorlds":
        return ColorWorlds(1, scene.physics.model.nmat, scene.frame_skip)

    def _edit_scene(self, physics) -> None:
        self._worlds.place(self._rows, 0, physics.model.mat_rgba[None])

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.zeros((scene.physics.model.nmat, 3), dtype=np.float32)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(scale={self.scale}, dynamic={self.dynamic})"


@njit(cache=True, nogil=True)
def _walk(rows, steps, noise, start, std, low, high, rgb):  # pragma: no cover - compiled
    """``steps[j]`` control steps of world ``i = rows[j]``'s colour walk: each channel ``c`` (of ``rgb[i]``,
    the materials' channels flat) moved by ``noise[i, start[j] + t C + c] * std[i]`` at step ``t`` and clipped to
    ``[low, high]``."""
    channels = rgb.shape[1]
    for j in range(rows.shape[0]):
        i = rows[j]
        low_i, high_i = low[i].ravel(), high[i].ravel()
        for t in range(steps[j]):
            at = start[j] + t * channels
            for c in range(channels):
                x = rgb[i, c] + noise[i, at + c] * std[i]
                rgb[i, c] = min(max(x, low_i[c]), high_i[c])


class ColorWorlds:
    """The colour distraction of N worlds as arrays: each world's material colours and their bounds
    (drawn at its episode start, :meth:`start`), walked and written for all the worlds at once
    (:meth:`advance`, :meth:`place`). A :class:`ColorDistraction` on one env keeps its state in a
    one-world instance; a batch keeps its worlds' in one (:meth:`ColorDistraction.share`).

    Args:
        n (int): the worlds.
        materials (int): the model's materials.
        frame_skip (int or array of int): control steps a world walks per agent step.
    """

    def __init__(self, n: int, materials: int, frame_skip):
        self.n = n
        self.frame_skip = per_world(frame_skip, n)
        self.rgb = np.zeros((n, materials, 3))
        self.low = np.zeros((n, materials, 3))
        self.high = np.zeros((n, materials, 3))
        self.std = np.zeros(n)  # the walk's sigma a control step
        self.placed = np.zeros(n, bool)  # the distraction sets the colours (active)
        self.moving = np.zeros(n, bool)  # ... at every control step (dynamic)
        self.noise = NoiseBank(n, materials * 3, self.frame_skip)

    def start(self, row: int, distraction: ColorDistraction) -> None:
        """World ``row``'s episode start: colours drawn within ``distraction``'s scale of the originals."""
        self.noise.rewind(row)
        original, scale = distraction._original, distraction.scale
        self.low[row] = np.clip(original - scale, 0.0, 1.0)
        self.high[row] = np.clip(original + scale, 0.0, 1.0)
        self.std[row] = _WALK_STD * scale
        self.placed[row] = scale > 0
        self.moving[row] = scale > 0 and distraction.dynamic
        self.rgb[row] = distraction._rng.uniform(self.low[row], self.high[row]) if scale > 0 else original

    def advance(self, rows: np.ndarray) -> None:
        """One agent step (each world's frame skip in control steps) of the walk of the worlds ``rows`` that move:
        N(0, σ) a channel and control step, clipped to the bounds."""
        rows = rows[self.moving[rows]]
        if len(rows):
            _walk(rows, self.frame_skip[rows], self.noise.values, self.noise.take(rows), self.std, self.low, self.high,
                  self.rgb.reshape(self.n, -1))

    def states(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The exposed state (float32 ``[materials, 3]``, the RGB) of the worlds ``rows`` (all: ``None``)."""
        return (self.rgb if rows is None else self.rgb[rows]).astype(np.float32)

    def place(self, rows: np.ndarray, offset: int, mat_rgba: np.ndarray) -> None:
        """Writes the colours of the worlds ``rows`` whose colours the distraction sets into
        ``mat_rgba[row - offset, :, :3]`` (alpha untouched)."""
        rows = rows[self.placed[rows]]
        if len(rows):
            mat_rgba[rows - offset, :, :3] = self.rgb[rows]
