"""LightingDistraction: the scene's lights turned, dimmed, tinted (beyond the paper: docs/lighting_textures.md).

The paper's abstract names lighting among what robots face but distracts only camera, colour and
background (Stone et al. 2021, Sec. 1 and 3). This distraction adds it with the paper's design: a scale
β_light in [0, 1], static (one draw an episode) or dynamic (a smooth bounded random walk, as the
camera's), seeded, exposed as data, the same on both renderers and in the batch.

A world's lighting is five numbers ``u`` in [-β, β] (:data:`AXES`), which at β = 1 span:

* ``tilt_x``, ``tilt_y``: each scene light orbits the point its axis meets the floor (z = 0) by up to
  :data:`MAX_TILT` about the world's x and y axes, still aimed at that point (harsh side and back light;
  its shadows move with it);
* ``gain``: every light's colour (the headlight's too) times ``1 ± GAIN_RANGE`` (dark to bright);
* ``temperature``: every light's colour tinted as a black body of ``6500 K · TEMPERATURE_RATIO^u``
  (warm orange to cold blue), at the luminance of white;
* ``ambient``: the headlight's ambient level ``± AMBIENT_RANGE``.

β = 0 edits nothing: the task's own lights, bit for bit.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from dcs_torchrl._scene import Scene, originals
from dcs_torchrl.distractions.base import DistractionTransform, check_scale, per_world
from dcs_torchrl.distractions.noise import NoiseBank

#: The five numbers of a world's lighting, in the order of ``u`` and of the exposed state.
AXES = ("tilt_x", "tilt_y", "gain", "temperature", "ambient")
#: The largest orbit of a light about each horizontal axis (β = 1).
MAX_TILT = math.radians(60.0)
#: The light colours' gain spans 1 ± this (β = 1).
GAIN_RANGE = 0.6
#: The colour temperature spans 6500 K times this to the power ±1 (β = 1): 2600 K to 16 250 K.
TEMPERATURE_RATIO = 2.5
WHITE_KELVIN = 6500.0
#: The headlight's ambient level moves by ± this (β = 1).
AMBIENT_RANGE = 0.25
#: The dynamic walk, per control step and in units of β: the velocity's σ and its largest speed (the
#: walk then crosses its range in about 200 control steps, a fifth of an episode of the six tasks).
_WALK_STD, _MAX_SPEED = 0.002, 0.01


def kelvin_rgb(kelvin) -> np.ndarray:
    """The RGB (each in [0, 1]) of a black body at ``kelvin`` (float or array; the widely used fit of
    Tanner Helland to the CIE 1964 colour matching functions), ``[..., 3]``."""
    t = np.asarray(kelvin, np.float64) / 100.0
    warm = t <= 66.0
    red = np.where(warm, 255.0, 329.698727446 * np.maximum(t - 60.0, 1e-9) ** -0.1332047592)
    green = np.where(warm, 99.4708025861 * np.log(np.maximum(t, 1e-9)) - 161.1195681661,
                     288.1221695283 * np.maximum(t - 60.0, 1e-9) ** -0.0755148492)
    blue = np.where(t >= 66.0, 255.0, np.where(t <= 19.0, 0.0,
                                              138.5177312231 * np.log(np.maximum(t - 10.0, 1e-9)) - 305.0447927307))
    return np.clip(np.stack([red, green, blue], axis=-1), 0.0, 255.0) / 255.0


_LUMA = np.array([0.2126, 0.7152, 0.0722])


def tint(kelvin) -> np.ndarray:
    """The RGB multiplier of light at ``kelvin`` against white light (6500 K): the black body's colour
    over white's, at white's luminance (Rec. 709 weights), ``[..., 3]``."""
    rgb = kelvin_rgb(kelvin) / kelvin_rgb(WHITE_KELVIN)
    return rgb / (rgb @ _LUMA)[..., None]


class LightingDistraction(DistractionTransform):
    """Turns, dims and tints the scene's lights, static or dynamic (beyond the paper; docs/lighting_textures.md).

    At each reset a world's five lighting numbers (:data:`AXES`) are drawn uniformly in [-β, β]; in the
    dynamic setting they then follow a velocity random walk bounded to that range, ``frame_skip``
    control steps per agent step. The physics never changes: after each physics step the lights' poses
    (``data.light_xpos`` / ``light_xdir``) are orbited and the colours of the lights and the headlight
    (``model.light_*``, ``model.vis.headlight``) scaled, before :class:`~dcs_torchrl.RenderPixels`
    renders. On the Warp backend the same numbers go to each world's lights
    (:class:`~dcs_torchrl.render.warp.WorldState`).

    Args:
        scale (float): β_light in [0, 1]. 0 leaves the lighting untouched.
        dynamic (bool): change the lighting at every control step. Defaults to ``False``.

    Keyword Args:
        seed (int, optional), expose (bool): see :class:`DistractionTransform`; the exposed state
            is float32 ``[tilt_x, tilt_y (radians), gain, temperature (kelvin), ambient offset]``.

    Examples:
        >>> from torchrl.envs import DMControlEnv, TransformedEnv, Compose
        >>> from dcs_torchrl import LightingDistraction, RenderPixels
        >>> env = TransformedEnv(
        ...     DMControlEnv("cartpole", "swingup", from_pixels=False, frame_skip=8),
        ...     Compose(LightingDistraction(0.5, dynamic=True, seed=0, expose=True), RenderPixels()),
        ... )
        >>> env.rollout(2)["next", "distractions", "lighting"].shape
        torch.Size([2, 5])
    """

    state_name = "lighting"
    seed_tag = 4

    def __init__(self, scale: float, dynamic: bool = False, *, seed: int | None = None, expose: bool = False):
        self.scale = check_scale("LightingDistraction scale", scale)
        self.dynamic = bool(dynamic)
        super().__init__(seed=seed, expose=expose)

    def _on_bind(self, scene: Scene) -> None:
        if self.scale > 0 and scene.physics.model.nlight == 0:
            raise ValueError(
                f"LightingDistraction(scale={self.scale}) needs a light to turn, and the {scene.domain!r} model "
                "has none: add a <light> to its worldbody, or leave light_scale at 0.")
        self._original = originals(scene.physics)

    def _new_worlds(self, scene: Scene) -> "LightingWorlds":
        return LightingWorlds(1, scene.frame_skip)

    def _edit_scene(self, physics) -> None:
        worlds, row = self._worlds, self.row
        if not worlds.placed[row]:
            return
        model, data, o = physics.model, physics.data, self._original
        _orbit(self._rows, 0, worlds.tilt(), data.light_xpos[None], data.light_xdir[None],
               data.light_xpos[None], data.light_xdir[None])
        gain, ambient = worlds.gain[row], worlds.ambient_offset(self._rows)[0]
        headlight = model.vis.headlight
        headlight.ambient[:] = (o.headlight_ambient + ambient) * gain
        headlight.diffuse[:] = o.headlight_diffuse * gain
        headlight.specular[:] = o.headlight_specular * gain
        model.light_ambient[:] = o.light_ambient * gain
        model.light_diffuse[:] = o.light_diffuse * gain
        model.light_specular[:] = o.light_specular * gain

    def hold(self, u) -> None:
        """Sets this env's lighting to the five numbers ``u`` (:data:`AXES`, each in units of its range at
        β = 1, within ``[-scale, scale]``) now, in its scene too: for pictures of the range (the gallery). The
        next reset draws anew; a dynamic walk goes on from ``u``."""
        u = np.asarray(u, np.float64)
        if u.shape != (len(AXES),) or np.any(np.abs(u) > self.scale + 1e-12):
            raise ValueError(f"hold takes the {len(AXES)} numbers {AXES}, each within the scale "
                             f"[-{self.scale}, {self.scale}]; got {u.tolist()}.")
        if self.worlds is None or not self._owner:
            raise RuntimeError("hold sets the lighting of the env this distraction owns: call env.reset() first "
                               "(a batch's worlds are set through their arrays).")
        self._worlds.u[self.row], self._worlds.velocity[self.row] = u, 0.0
        self._worlds._colour(self._rows)
        physics = self._bind().physics
        physics.forward()  # the lights' undistracted poses, to orbit again
        self._edit_scene(physics)

    def _state_like(self, scene: Scene) -> np.ndarray:
        return np.zeros(len(AXES), dtype=np.float32)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(scale={self.scale}, dynamic={self.dynamic})"


@njit(cache=True, nogil=True)
def _walk(rows, steps, noise, start, u, velocity, bound, std, max_speed):  # pragma: no cover - compiled
    """``steps[j]`` control steps of world ``i = rows[j]``'s velocity walk of its five numbers ``u[i]``: the
    velocity moved by ``noise[i, start[j] + 5 t:][:5] * std[i]`` at step ``t``, its length clipped to
    ``max_speed[i]``, added to ``u[i]``, which is clipped to ``[-bound[i], bound[i]]`` (the velocity then
    re-derived from the clipped move, so that it never keeps pushing out of range)."""
    width = u.shape[1]
    for j in range(rows.shape[0]):
        i = rows[j]
        for t in range(steps[j]):
            at = start[j] + t * width
            speed = 0.0
            for c in range(width):
                velocity[i, c] += noise[i, at + c] * std[i]
                speed += velocity[i, c] * velocity[i, c]
            speed = math.sqrt(speed)
            shrink = max_speed[i] / speed if speed > max_speed[i] else 1.0
            for c in range(width):
                moved = min(max(u[i, c] + velocity[i, c] * shrink, -bound[i]), bound[i])
                velocity[i, c] = moved - u[i, c]
                u[i, c] = moved


@njit(cache=True, nogil=True)
def _orbit(rows, offset, tilt, light_xpos, light_xdir, out_xpos, out_xdir):  # pragma: no cover - compiled
    """Each light of world ``i = rows[j]`` (row ``i`` of ``light_xpos`` / ``light_xdir``, ``[N, nlight, 3]``)
    orbited about the point its axis meets the floor (z = 0; one unit along the axis for a light that
    does not point down) by the rotation ``Ry(tilt[i, 1]) Rx(tilt[i, 0])``, written into row ``i - offset``
    of ``out_xpos`` / ``out_xdir`` (any float dtype; may be the inputs)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        cx, sx = math.cos(tilt[i, 0]), math.sin(tilt[i, 0])
        cy, sy = math.cos(tilt[i, 1]), math.sin(tilt[i, 1])
        # R = Ry Rx, row-major
        r00, r01, r02 = cy, sy * sx, sy * cx
        r10, r11, r12 = 0.0, cx, -sx
        r20, r21, r22 = -sy, cy * sx, cy * cx
        for k in range(light_xpos.shape[1]):
            px, py, pz = light_xpos[i, k, 0], light_xpos[i, k, 1], light_xpos[i, k, 2]
            dx, dy, dz = light_xdir[i, k, 0], light_xdir[i, k, 1], light_xdir[i, k, 2]
            reach = -pz / dz if dz < -1e-6 and pz > 0.0 else 1.0
            qx, qy, qz = px + dx * reach, py + dy * reach, pz + dz * reach  # the pivot
            ax, ay, az = px - qx, py - qy, pz - qz
            o = i - offset
            out_xpos[o, k, 0] = qx + r00 * ax + r01 * ay + r02 * az
            out_xpos[o, k, 1] = qy + r10 * ax + r11 * ay + r12 * az
            out_xpos[o, k, 2] = qz + r20 * ax + r21 * ay + r22 * az
            out_xdir[o, k, 0] = r00 * dx + r01 * dy + r02 * dz
            out_xdir[o, k, 1] = r10 * dx + r11 * dy + r12 * dz
            out_xdir[o, k, 2] = r20 * dx + r21 * dy + r22 * dz


class LightingWorlds:
    """The lighting distraction of N worlds as arrays: each world's five numbers ``u`` (:data:`AXES`, in
    [-β, β]) and their walk's velocity, drawn at its episode start (:meth:`start`), walked and placed for all
    the worlds at once (:meth:`advance`, :meth:`place`). A :class:`LightingDistraction` on one env keeps
    its state in a one-world instance; a batch keeps its worlds' in one (:meth:`LightingDistraction.share`).

    Args:
        n (int): the worlds.
        frame_skip (int or array of int): control steps a world walks per agent step.
    """

    def __init__(self, n: int, frame_skip):
        self.n = n
        self.frame_skip = per_world(frame_skip, n)
        self.u = np.zeros((n, len(AXES)))
        self.velocity = np.zeros((n, len(AXES)))
        self.bound = np.zeros(n)  # β
        self.std = np.zeros(n)
        self.max_speed = np.zeros(n)
        self.gain = np.ones((n, 3))  # the lights' RGB gain: gain times the temperature's tint
        self.placed = np.zeros(n, bool)  # the distraction sets the lighting (active)
        self.moving = np.zeros(n, bool)  # ... at every control step (dynamic)
        self.noise = NoiseBank(n, len(AXES), self.frame_skip)

    def start(self, row: int, distraction: LightingDistraction) -> None:
        """World ``row``'s episode start: its five numbers drawn uniformly within ``distraction``'s scale."""
        self.noise.rewind(row)
        scale = distraction.scale
        self.bound[row], self.std[row], self.max_speed[row] = scale, _WALK_STD * scale, _MAX_SPEED * scale
        self.placed[row] = scale > 0
        self.moving[row] = scale > 0 and distraction.dynamic
        self.velocity[row] = 0.0
        self.u[row] = distraction._rng.uniform(-scale, scale, len(AXES)) if scale > 0 else 0.0
        self._colour(np.array([row]))

    def _colour(self, rows: np.ndarray) -> None:
        u = self.u[rows]
        self.gain[rows] = (1.0 + GAIN_RANGE * u[:, 2:3]) * tint(WHITE_KELVIN * TEMPERATURE_RATIO ** u[:, 3])

    def advance(self, rows: np.ndarray) -> None:
        """One agent step (each world's frame skip in control steps) of the walk of the worlds ``rows`` that move."""
        rows = rows[self.moving[rows]]
        if len(rows):
            _walk(rows, self.frame_skip[rows], self.noise.values, self.noise.take(rows), self.u, self.velocity,
                  self.bound, self.std, self.max_speed)
            self._colour(rows)

    def tilt(self) -> np.ndarray:
        """Every world's tilts about x and y in radians, ``[N, 2]``."""
        return self.u[:, :2] * MAX_TILT

    def ambient_offset(self, rows: np.ndarray) -> np.ndarray:
        """The headlight's ambient offset of the worlds ``rows``, ``[len(rows)]``."""
        return AMBIENT_RANGE * self.u[rows, 4]

    def place(self, rows: np.ndarray, offset: int, light_xpos, light_xdir, light_ambient0, out_xpos, out_xdir,
              out_ambient, out_gain) -> None:
        """Writes the lighting of the worlds ``rows`` whose lighting the distraction sets into row ``row -
        offset`` of the renderer's arrays (:class:`~dcs_torchrl.render.warp.WorldState`): the lights orbited
        from the new state's ``light_xpos`` / ``light_xdir`` (``[N, nlight, 3]``) into ``out_xpos`` /
        ``out_xdir``; ``out_gain`` ``[.., 3]`` the lights' gain (the renderer scales what they light by it,
        the headlight included); ``out_ambient`` ``[.., nlight, 3]`` the model's ``light_ambient0`` with the
        headlight's ambient offset, unscaled, on the first light (the renderer adds every light's ambient
        as the headlight's, before the gain)."""
        rows = rows[self.placed[rows]]
        if not len(rows):
            return
        local = rows - offset
        _orbit(rows, offset, self.tilt(), light_xpos, light_xdir, out_xpos, out_xdir)
        out_gain[local] = self.gain[rows]
        out_ambient[local] = light_ambient0
        out_ambient[local, 0] += self.ambient_offset(rows)[:, None]

    def states(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The exposed state (float32 ``[tilt_x, tilt_y, gain, temperature, ambient offset]``) of the worlds
        ``rows`` (all: ``None``)."""
        u = self.u if rows is None else self.u[rows]
        return np.stack([u[:, 0] * MAX_TILT, u[:, 1] * MAX_TILT, 1.0 + GAIN_RANGE * u[:, 2],
                         WHITE_KELVIN * TEMPERATURE_RATIO ** u[:, 3], AMBIENT_RANGE * u[:, 4]], axis=1).astype(np.float32)
