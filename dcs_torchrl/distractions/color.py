"""ColorDistraction: random colours for every material of the scene (Stone et al. 2021, Sec. 3.2)."""
from __future__ import annotations

import numpy as np

from dcs_torchrl._scene import Scene, originals
from dcs_torchrl.distractions.base import DistractionTransform, check_scale

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
    step_attributes = frozenset({"_rgb"})

    def __init__(self, scale: float, dynamic: bool = False, *, seed: int | None = None, expose: bool = False):
        self.scale = check_scale("ColorDistraction scale", scale)
        self.dynamic = bool(dynamic)
        self._rgb: np.ndarray | None = None
        super().__init__(seed=seed, expose=expose)

    def _on_bind(self, scene: Scene) -> None:
        original = originals(scene.physics).mat_rgba[:, :3].astype(np.float64)
        self._low = np.clip(original - self.scale, 0.0, 1.0)
        self._high = np.clip(original + self.scale, 0.0, 1.0)
        self._rgb = original.copy()

    def _start(self, physics) -> None:
        if self.scale > 0:
            self._rgb = self._rng.uniform(self._low, self._high)

    def _advance(self, n_steps: int) -> None:
        if self.scale > 0 and self.dynamic:
            rgb = self._rgb.copy()  # the exposed state of the last step stays as it was
            for step in self._rng.standard_normal((n_steps, *rgb.shape)) * (_WALK_STD * self.scale):
                rgb += step  # then clipped to [low, high], in place
                np.maximum(rgb, self._low, out=rgb)
                np.minimum(rgb, self._high, out=rgb)
            self._rgb = rgb

    def _edit_scene(self, physics) -> None:
        if self.scale > 0:
            physics.model.mat_rgba[:, :3] = self._rgb

    def _state(self) -> np.ndarray:
        return self._rgb.astype(np.float32)

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.zeros((scene.physics.model.nmat, 3), dtype=np.float32)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(scale={self.scale}, dynamic={self.dynamic})"
