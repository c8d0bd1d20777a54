"""BatchedSuiteEnv: N suite envs in one process, their physics stepped here, rendered in one batch (MuJoCo Warp).

``make_env(domain, task, ..., num_envs=N, backend="warp", device=...)`` builds it. Each env is the
GL env's physics, task and distractions without its render: a
``TransformedEnv(DMControlEnv(domain, task, from_pixels=False, frame_skip=k), Compose(CameraDistraction,
ColorDistraction, BackgroundDistraction))``, seeded as TorchRL's batched envs seed their workers (env
``i`` gets the seed env ``i - 1``'s ``set_seed`` returns). A reset goes through that env's own TorchRL
``reset`` (the task's ``initialize_episode``). A step of the paper's six tasks
(:data:`dcs_torchrl.vector.task_arrays.TASKS`) runs every env's physics in one compiled call over MuJoCo's C and
the task's reward and observation over arrays (:class:`~dcs_torchrl.vector.batch_physics.BatchPhysics`); any other
task runs its dm_control env ``k`` times with the action, as ``DMControlEnv`` does. Then the distractions, over
arrays of all the worlds: each env's transforms keep their state in a row of the batch's ``CameraWorlds``,
``ColorWorlds``, ``BackgroundWorlds``, ``LightingWorlds`` and ``TextureWorlds``
(:meth:`~dcs_torchrl.distractions.base.DistractionTransform.share`), which one call each advances. So env
``i``'s rewards, resets, terminations and distraction draws are those of
env ``i`` of ``ParallelSuiteEnv(N, partial(make_env, ...))`` seeded alike, bit for bit
(``tests/test_batched.py``). Then the N worlds' poses (:class:`~dcs_torchrl.vector.kinematics.Kinematics`), the
distractions' cameras, colours, lights and material textures and the skies
(:class:`~dcs_torchrl.render.skies.BatchSkies`) go, as whole arrays, to one
:class:`~dcs_torchrl.render.warp.WarpRenderer` call on ``device``: ``"pixels"`` is uint8 [N, H, W, 3] there.

Partial resets (``"_reset"``) and partial steps (``"_step"``, which TorchRL's ``rollout`` writes) act on
the envs they name only; the others continue their episodes.
"""
from __future__ import annotations

import functools
import re
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import cv2
import mujoco
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Composite
from torchrl.envs import EnvBase, TransformedEnv

from dcs_torchrl._scene import locate, originals
from dcs_torchrl.distractions import (BackgroundDistraction, CameraDistraction, ColorDistraction, LightingDistraction,
                                      TextureDistraction)
from dcs_torchrl.distractions.background import BackgroundWorlds
from dcs_torchrl.distractions.base import DistractionTransform
from dcs_torchrl.distractions.camera import CameraWorlds
from dcs_torchrl.distractions.color import ColorWorlds
from dcs_torchrl.distractions.lighting import LightingWorlds
from dcs_torchrl.distractions.texture import TextureWorlds
from dcs_torchrl.render.gl import check_profile
from dcs_torchrl.render.skies import BatchSkies
from dcs_torchrl.render.warp import MASK_LABELS, WarpRenderer
from dcs_torchrl.vector._batching import chain_seeds, close_once, marked, shares
from dcs_torchrl.vector.batch_physics import BatchPhysics
from dcs_torchrl.vector.kinematics import Kinematics
from dcs_torchrl.vector.task_arrays import task_arrays

__all__ = ["BatchedSuiteEnv", "WARP_PROFILES", "compact_skies", "scene_labels"]

#: The Warp backend's render settings by ``render_profile`` (the names of GL's
#: :data:`dcs_torchrl.render.gl.PROFILES`): ``"default"`` draws shadows as GL's default profile does; ``"fast"`` none.
WARP_PROFILES = {"default": {"shadows": True}, "fast": {"shadows": False}}


def scene_labels(model) -> tuple[np.ndarray, np.ndarray]:
    """Per geom ``(agent, floor)``: agent = a geom of any body but the world (the robot and the task's
    moving bodies); floor = a plane of the world body. Every other pixel is background (the sky and
    the other static geoms)."""
    body = np.asarray(model.geom_bodyid)
    plane = np.asarray(model.geom_type) == mujoco.mjtGeom.mjGEOM_PLANE
    return body != 0, (body == 0) & plane


#: Default number of parts a batch is rendered in (:class:`BatchedSuiteEnv`'s ``render_chunks``).
RENDER_CHUNKS = 4
#: Threads that render parts at once (each part has its own Warp context): while this thread steps
#: physics one renders beside it; once the physics is done, the others too.
RENDER_THREADS = 2


def _chunks(n: int, parts: int | None) -> list[range]:
    """``n`` envs in ``parts`` contiguous, near-equal ranges."""
    parts = RENDER_CHUNKS if parts is None else parts
    if isinstance(parts, bool) or not isinstance(parts, int) or parts < 1:
        raise ValueError(f"render_chunks must be a positive integer (or None), got {parts!r}.")
    return shares(n, parts)


#: The texture distraction's blends go to the Warp renderers at this fraction of their side (area-averaged):
#: Warp samples a texture once a pixel without mipmaps, so a coarser copy aliases less where the surface is
#: seen from afar, and each world's own texture, read by rays of all the worlds, takes a quarter of the memory
#: (docs/lighting_textures.md, "Both renderers" and "Cost").
TEXTURE_TABLE_REDUCTION = 2


def _reduced(images: np.ndarray, factor: int) -> np.ndarray:
    """uint8 ``[K, h, w, 3]`` images at ``1 / factor`` of their side (at least one texel), area-averaged."""
    if factor == 1:
        return images
    h, w = max(1, images.shape[1] // factor), max(1, images.shape[2] // factor)
    return np.stack([cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA) for image in images])


_SKYBOX_ASSET = "./common/skybox.xml"  # dm_control's suite models include it (800 x 800 texels a face)


@contextmanager
def compact_skies(settings) -> Iterator[None]:
    """dm_control suite models compiled meanwhile get a skybox of ``settings.texture_size`` texels a
    face instead of 800, where the envs of these settings never read their model's sky: for the envs
    of a batch after the first, whose own sky is never rendered (the batch renders from the first
    env's model, and each env's background distraction hands its sky to the renderer). An env reads
    its sky only to blend videos onto it (``0 < background_blend < 1``); then nothing changes. The
    physics are the same; each model then holds ``texture_size``² texels of sky a face instead of 800²
    (docs/performance.md, "Memory")."""
    from dm_control.suite import common

    original = common.ASSETS.get(_SKYBOX_ASSET)
    if original is None or (settings.num_videos > 0 and 0 < settings.background_blend < 1):
        yield
        return
    side = int(settings.texture_size)
    text = original.decode() if isinstance(original, bytes) else original
    compact = re.sub(r'width="\d+" height="\d+"', f'width="{side}" height="{side}"', text)
    common.ASSETS[_SKYBOX_ASSET] = compact.encode() if isinstance(original, bytes) else compact
    try:
        yield
    finally:
        common.ASSETS[_SKYBOX_ASSET] = original


class _World:
    """One env of the batch: its TorchRL env (physics, task, distractions) and the arrays it fills."""

    def __init__(self, env: TransformedEnv):
        self.env = env
        self.base = env.base_env
        self.dm = self.base._env  # the dm_control Environment DMControlEnv steps
        self.frame_skip = int(self.base.wrapper_frame_skip)
        self.distractions = [t for t in env.transform if isinstance(t, DistractionTransform)]
        self.exposed = [t for t in self.distractions if t.expose]
        self.background = next((t for t in self.distractions if isinstance(t, BackgroundDistraction)), None)
        self.physics = locate(self.distractions[0], strict=True).physics if self.distractions else self.dm.physics

    def step(self, action: np.ndarray) -> TensorDictBase:
        """The TorchRL env's own step of its base env (``DMControlEnv``: the frame skip, stopping at the
        episode's end), without the distractions (the batch steps them, over all the worlds). Returns its ``"next"``."""
        return self.base.step(TensorDict({"action": torch.from_numpy(action)}, []))["next"]


class BatchedSuiteEnv(EnvBase):
    """N suite envs stepped in this process and rendered in one MuJoCo Warp call: batch size ``[N]``.

    Built by :func:`dcs_torchrl.make_env` with ``num_envs=N, backend="warp"``; see the module's text.

    Args:
        envs (sequence of TransformedEnv): the N envs without a render, as ``make_env`` builds them
            (a ``DMControlEnv(from_pixels=False)`` under the suite's distractions), one task. Their
            distraction settings may differ (:func:`dcs_torchrl.make_grouped_env`), but either all
            show background videos, at one ``texture_size``, or none does.

    Keyword Args:
        height, width (int): the image size.
        camera_id (int): the camera rendered.
        device: where the batch lives and Warp renders: ``"cpu"`` or a CUDA device.
        pixels_only (bool): drop the task's state observations.
        masks (bool): add ``"masks"``, uint8 [N, H, W], labels :data:`~dcs_torchrl.render.warp.MASK_LABELS`.
        render_profile (str): a key of :data:`WARP_PROFILES`.
        render_chunks (int, optional): render the batch in this many parts, each while the next
            part's physics steps (``None``: :data:`RENDER_CHUNKS`, at most one per env). The pixels
            are the same for any value.
        groups (sequence of int, optional): the sizes of consecutive groups of ``envs`` that
            :meth:`set_seed` seeds apart, each as a batch of its own (``None``: one group). So each
            group's envs run the episodes a batch of that group's envs alone runs.
        physics_threads (int, optional): threads the physics of a task of
            :data:`dcs_torchrl.vector.task_arrays.TASKS` run on (``None``: the cores this process may use);
            other tasks step through dm_control's Python, env by env (:attr:`physics` is ``None``).
        sky_table (bool, optional): where the worlds' video frames (shown alone, ``background_blend``
            1) are read from: a table holding each clip once, each world a row number (``True``: a
            step copies no frame, a CUDA device receives each clip once), or each world's own row,
            its frame copied in at each step (``False``: no second copy of the clips in memory).
            ``None``: the table on a CUDA device and from :data:`~dcs_torchrl.render.skies.TABLE_FROM` envs,
            else the rows. The pixels are the same.
    """

    def __init__(self, envs: Sequence[TransformedEnv], *, height: int = 84, width: int = 84, camera_id: int = 0,
                 device="cpu", pixels_only: bool = True, masks: bool = False, render_profile: str = "default",
                 render_chunks: int | None = None, groups: Sequence[int] | None = None,
                 physics_threads: int | None = None, sky_table: bool | None = None):
        check_profile(render_profile)
        envs = list(envs)
        if not envs:
            raise ValueError("BatchedSuiteEnv needs at least one env (num_envs >= 1).")
        groups = [len(envs)] if groups is None else [int(size) for size in groups]
        if sum(groups) != len(envs) or min(groups) < 1:
            raise ValueError(f"groups must be positive sizes summing to the {len(envs)} envs, got {groups}.")
        self._groups = groups
        device = torch.device(device)
        super().__init__(batch_size=[len(envs)], device=device)
        self.num_envs = n = len(envs)
        self._worlds = [_World(env) for env in envs]
        first = self._worlds[0]
        self._state_keys = list(first.base.observation_spec.keys(True, True))
        self.pixels_only, self.masks = bool(pixels_only), bool(masks)
        self._set_specs(first.env, height, width)
        model = first.physics.model
        # the distractions' state over the worlds: each world's transforms keep theirs in a row of these
        frame_skip = np.array([w.frame_skip for w in self._worlds], np.int64)
        self._camera, self._color = CameraWorlds(n, frame_skip), ColorWorlds(n, model.nmat, frame_skip)
        self._background = BackgroundWorlds(n, frame_skip)
        self._lighting, self._texture = LightingWorlds(n, frame_skip), TextureWorlds(n)
        arrays = {CameraDistraction: self._camera, ColorDistraction: self._color,
                  BackgroundDistraction: self._background, LightingDistraction: self._lighting,
                  TextureDistraction: self._texture}
        for i, world in enumerate(self._worlds):
            for t in world.distractions:
                t.share(arrays[type(t)], i)
        self._exposed = {t.out_keys[0]: arrays[type(t)] for t in first.distractions if t.expose}
        agent, floor = scene_labels(model)
        # the batch is rendered in chunks, each by its own renderer, in a thread of its own while
        # this thread steps the next chunk's physics (Warp's launches release the GIL)
        self._chunks = _chunks(n, render_chunks)
        self.renderers = [WarpRenderer(model, len(chunk), height, width, camera_id, device,
                                       agent_geoms=agent if masks else None, floor_geoms=floor,
                                       **WARP_PROFILES[render_profile]) for chunk in self._chunks]
        self.skies = BatchSkies(model, [w.background for w in self._worlds], self._background.frame,
                                self._background.changed, self._chunks, height, camera_id, sky_table,
                                device.type == "cuda")
        self._scenes = [renderer.state(self.skies.array(c)) for c, renderer in enumerate(self.renderers)]
        self._add_textures()
        self._model_texid = np.asarray(model.mat_texid)[:, int(mujoco.mjtTextureRole.mjTEXROLE_RGB)].astype(np.int32)
        self._light_ambient = originals(first.physics).light_ambient.astype(np.float32)
        self._kinematics = Kinematics([w.physics.data.ptr for w in self._worlds])
        self._pixels = torch.zeros((n, height, width, 3), dtype=torch.uint8, device=device)
        self._labels = torch.zeros((n, height, width), dtype=torch.uint8, device=device) if masks else None
        self._pool = ThreadPoolExecutor(RENDER_THREADS, thread_name_prefix="warp-render") if len(self._chunks) > 1 else None
        self._pending: list = []
        self._obs = {key: np.zeros(spec.shape, np.float64) for key, spec in self._state_obs_spec.items(True, True)}
        self._reward = np.zeros((n, 1), np.float64)
        self._done = np.zeros((n, 3), bool)  # terminated, truncated, done
        self._states = {key: np.zeros(spec.shape, torch.empty((), dtype=spec.dtype).numpy().dtype)
                        for key, spec in self.observation_spec.items(True, True) if key in self._exposed}
        self.physics = self._batch_physics(physics_threads)
        #: seconds spent stepping: ``"physics"`` (the envs' physics and task), ``"scene"`` (the
        #: distractions' step and the worlds' scenes into the render's arrays), for the benchmarks
        self.seconds = {"physics": 0.0, "scene": 0.0}
        self.is_closed = False

    # ------------------------------------------------------------------ set-up
    def _batch_physics(self, threads: int | None) -> BatchPhysics | None:
        """The envs' physics stepped in MuJoCo's C and their task over arrays, where the task is one of
        :data:`~dcs_torchrl.vector.task_arrays.TASKS`; ``None`` (dm_control's step, env by env) otherwise."""
        first = self._worlds[0].base
        arrays = task_arrays(first.env_name, first.task_name, self._worlds[0].dm.task)
        if arrays is None or any(task_arrays(w.base.env_name, w.base.task_name, w.dm.task) is not arrays
                                 or not w.dm.physics.legacy_step for w in self._worlds):
            return None  # BatchPhysics steps as dm_control's legacy step (its default) does
        return BatchPhysics([w.dm for w in self._worlds], arrays, [w.frame_skip for w in self._worlds], threads)

    def _set_specs(self, env: TransformedEnv, height: int, width: int) -> None:
        n, device = self.num_envs, self.device
        observation = env.observation_spec.clone()
        self._state_obs_spec = Composite({key: observation[key] for key in self._state_keys}).expand(n).to(device)
        if self.pixels_only:
            for key in self._state_keys:
                del observation[key]
        observation["pixels"] = Bounded(0, 255, shape=(height, width, 3), dtype=torch.uint8, device=device)
        if self.masks:
            observation["masks"] = Bounded(0, max(MASK_LABELS.values()), shape=(height, width), dtype=torch.uint8,
                                           device=device)
        self.observation_spec = observation.expand(n).to(device)
        self.action_spec = env.action_spec.expand(n, *env.action_spec.shape).to(device)
        self.reward_spec = env.reward_spec.expand(n, *env.reward_spec.shape).to(device)
        self.done_spec = env.full_done_spec.expand(n).to(device)

    def _add_textures(self) -> None:
        """Every texture distraction's blends (each set once) among every renderer's textures, and each
        world told where its own lie (:attr:`TextureWorlds.first`)."""
        added: dict[int, int] = {}
        for i, world in enumerate(self._worlds):
            t = next((t for t in world.distractions if isinstance(t, TextureDistraction)), None)
            if t is None or t.scale == 0:
                continue
            for column, images in enumerate((t.floor_images, t.body_images)):
                if images is None or not images.size:
                    continue
                if id(images) not in added:
                    table = _reduced(images, TEXTURE_TABLE_REDUCTION)
                    added[id(images)] = [r.add_textures(table) for r in self.renderers][0]
                self._texture.first[i, column] = added[id(images)]

    # --------------------------------------------------------------- gathering
    def _place(self, chunk: int, rows: np.ndarray, started: bool = False) -> None:
        """The scene of the worlds ``rows`` (int64, all in part ``chunk``) into that part's arrays, as whole
        arrays: their new state's poses (gathered from their ``MjData``), their distractions' camera,
        colours and sky, and their exposed distraction states. ``started``: their episodes began."""
        if not len(rows):
            return
        scene, offset, kinematics = self._scenes[chunk], self._chunks[chunk].start, self._kinematics.fields
        self._kinematics.gather(rows)
        local = rows - offset
        for field in ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir"):
            getattr(scene, field)[local] = kinematics[field][rows]
        if started:  # a world's materials as its episode starts them (the floor's alpha); the colours below
            scene.mat_rgba[local] = np.stack([self._worlds[i].physics.model.mat_rgba for i in rows.tolist()])
            scene.mat_texid[local] = self._model_texid
            self._texture.place(rows, offset, scene.mat_texid)
            self.skies.started(rows.tolist())
        self._camera.place(rows, offset, kinematics["cam_xpos"], kinematics["cam_xmat"], kinematics["subtree_com"],
                           kinematics["xpos"], scene.cam_xpos, scene.cam_xmat)
        self._color.place(rows, offset, scene.mat_rgba)
        self._lighting.place(rows, offset, kinematics["light_xpos"], kinematics["light_xdir"], self._light_ambient,
                             scene.light_xpos, scene.light_xdir, scene.light_ambient, scene.light_gain)
        self.skies.update(chunk, scene, rows)
        for key, worlds in self._exposed.items():
            self._states[key][rows] = worlds.states(rows)

    def _render_chunk(self, chunk: int) -> None:
        """Renders chunk ``chunk`` into this env's pixel (and label) buffers: now, or in the render
        thread while the caller goes on."""
        span = self._chunks[chunk]

        def render():
            pixels, labels = self.renderers[chunk].render(self._scenes[chunk])
            self._pixels[span.start:span.stop].copy_(pixels)
            if labels is not None:
                self._labels[span.start:span.stop].copy_(labels)

        if self._pool is None:
            render()
        else:
            self._pending.append(self._pool.submit(render))

    def _each_chunk(self, indices, act) -> None:
        """``act(chunk, worlds)`` for the worlds ``indices`` of each chunk in turn (int64, maybe empty), each chunk
        rendered once its worlds are done (every chunk is rendered, so that every env's frame is its
        current scene), while the next chunk's worlds are acted on."""
        todo = np.zeros(self.num_envs, bool)
        todo[indices] = True
        for chunk, span in enumerate(self._chunks):
            act(chunk, span.start + np.flatnonzero(todo[span.start:span.stop]))
            self._render_chunk(chunk)
        pending, self._pending = self._pending, []
        for future in pending:
            future.result()

    def _output(self, with_reward: bool) -> TensorDictBase:
        out = {"pixels": self._pixels.clone()}
        if self._labels is not None:
            out["masks"] = self._labels.clone()
        if not self.pixels_only:
            out.update({key: torch.from_numpy(value.copy()) for key, value in self._obs.items()})
        for key, value in self._states.items():
            out[key] = torch.from_numpy(value.copy())
        done = torch.from_numpy(self._done.copy())
        out.update(terminated=done[:, 0:1], truncated=done[:, 1:2], done=done[:, 2:3])
        if with_reward:
            out["reward"] = torch.from_numpy(self._reward.copy()).to(self.reward_spec.dtype)
        return TensorDict(out, batch_size=self.batch_size).to(self.device)

    # ------------------------------------------------------------- TorchRL hooks
    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        self._check_open()
        actions = tensordict.get(self.action_key).detach().cpu().numpy()
        indices = marked(tensordict, "_step", self.num_envs)
        self._reward[:] = 0.0

        def step(chunk: int, worlds: np.ndarray) -> None:
            start = time.perf_counter()
            over = np.ones(len(worlds), bool) if self.physics is None else self.physics.ended[worlds]
            fast, slow = worlds[~over], worlds[over]  # slow: other tasks, and episodes over (dm_control's step resets them)
            if len(fast):  # MuJoCo's C in one call, the task over arrays
                reward, truncated, observation = self.physics.step(fast, actions[fast], observe=not self.pixels_only)
                self._reward[fast, 0] = reward
                self._done[fast] = np.stack([np.zeros_like(truncated), truncated, truncated], axis=-1)
                for key in self._state_keys if observation is not None else ():
                    self._obs[key][fast] = observation[key].reshape(self._obs[key][fast].shape)
            for i in slow.tolist():
                out = self._worlds[i].step(actions[i])  # dm_control's step, through TorchRL's DMControlEnv
                if self.physics is not None:  # an episode over: dm_control's step reset it (the task drew anew)
                    self.physics.after_reset(i)
                self._reward[i] = out["reward"].item()
                self._done[i] = [out[key].item() for key in ("terminated", "truncated", "done")]
                for key in self._state_keys:
                    self._obs[key][i] = out[key].numpy()
            physics = time.perf_counter()
            for worlds_of in (self._camera, self._color, self._background, self._lighting):  # the distractions over arrays
                worlds_of.advance(worlds)
            self._place(chunk, worlds)
            self.seconds["physics"] += physics - start
            self.seconds["scene"] += time.perf_counter() - physics

        self._each_chunk(indices, step)
        return self._output(with_reward=True)

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        self._check_open()
        indices = marked(tensordict, "_reset", self.num_envs)

        def reset(chunk: int, worlds: np.ndarray) -> None:
            for i in worlds.tolist():  # a world's own reset (physics, task, distractions' draws): an episode start
                observation = self._worlds[i].env.reset()
                if self.physics is not None:
                    self.physics.after_reset(i)
                self._done[i] = False
                for key in self._state_keys:
                    self._obs[key][i] = observation.get(key).numpy()
            self._place(chunk, worlds, started=True)

        self._each_chunk(indices, reset)
        return self._output(with_reward=False)

    def set_seed(self, seed: int | None = None, static_seed: bool = False) -> int | None:
        """Seeds env 0 with ``seed`` and each next env with what the previous one's ``set_seed``
        returns (TorchRL's batched envs); with ``groups``, each group so from ``seed``. Returns the
        last env's return."""
        worlds, chained = iter(self._worlds), seed
        for size in self._groups:
            chained = chain_seeds([functools.partial(next(worlds).env.set_seed, static_seed=static_seed)
                                   for _ in range(size)], seed)
        return chained

    def _set_seed(self, seed: int | None) -> None:  # set_seed is overridden: never called
        raise NotImplementedError

    def _check_open(self) -> None:
        if self.is_closed:
            raise RuntimeError("this BatchedSuiteEnv is closed: build a new one with make_env.")

    def close(self, *, raise_if_closed: bool = True) -> None:
        if not close_once(self, raise_if_closed):
            return
        if self._pool is not None:
            self._pool.shutdown()
        if self.physics is not None:
            self.physics.close()
        for world in self._worlds:
            world.env.close()
