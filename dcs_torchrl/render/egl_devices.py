"""Which GPU renders: the machine's EGL devices, and the one that is a given CUDA device.

dm_control renders on the EGL device that ``MUJOCO_EGL_DEVICE_ID`` names when a process first
imports its EGL renderer (``import dcs_torchrl`` does), an index into the list that
``eglQueryDevicesEXT`` returns. That index is not the CUDA ordinal: Mesa's software device, other
vendors' GPUs and ``CUDA_VISIBLE_DEVICES`` all move one numbering and not the other. NVIDIA's EGL
driver says which CUDA device each of its EGL devices is (the ``EGL_NV_device_cuda`` extension,
in this process's CUDA numbering), which is how :func:`egl_device_of_cuda` finds the EGL device
of the GPU a policy runs on, so that a run's envs render on the GPU that acts
(:class:`~dcs_torchrl.ParallelSuiteEnv`'s ``render_devices``, the recipes'
``execution.render_device``).

The queries go to ``libEGL`` through ctypes and create no display or context, so they cost
nothing and work in a process that already renders.

Examples:
    >>> from dcs_torchrl.render.egl_devices import egl_devices
    >>> devices = egl_devices()  # Mesa on a CPU machine: one software device, no CUDA
    >>> devices[0].index, isinstance(devices[0].extensions, tuple)
    (0, True)
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import torch

__all__ = ["EGLDevice", "egl_device_environment", "egl_device_of_cuda", "egl_devices", "process_render_device",
           "render_device_index", "render_device_indices", "render_threads_share", "spawn_environment"]

#: The environment variable dm_control reads, once per process, for the EGL device it renders on.
EGL_DEVICE_VARIABLE = "MUJOCO_EGL_DEVICE_ID"

_EGL_EXTENSIONS = 0x3055
_EGL_DRM_DEVICE_FILE_EXT = 0x3233
_EGL_CUDA_DEVICE_NV = 0x323A
_EGL_TRUE = 1
_MAX_DEVICES = 64


@dataclass(frozen=True)
class EGLDevice:
    """One EGL device: its index (what ``MUJOCO_EGL_DEVICE_ID`` takes), the device extensions its
    driver lists, the CUDA ordinal it is in this process (``None`` where its driver does not say:
    Mesa, other vendors) and its DRM device file where the driver gives one."""

    index: int
    extensions: tuple[str, ...]
    cuda: int | None
    drm: str | None

    def describe(self) -> str:
        """``"1 (CUDA device 0, /dev/dri/card1)"``, ``"0 (software: EGL_MESA_device_software)"``..."""
        if self.cuda is not None:
            what = f"CUDA device {self.cuda}"
        elif "EGL_MESA_device_software" in self.extensions:
            what = "software: EGL_MESA_device_software"
        else:
            what = "no CUDA device"
        return f"{self.index} ({what}{', ' + self.drm if self.drm else ''})"


@functools.cache
def _egl():
    """``libEGL``'s three device queries as ctypes functions (resolved once per process)."""
    name = ctypes.util.find_library("EGL") or "libEGL.so.1"
    try:
        lib = ctypes.CDLL(name)
    except OSError as error:
        raise RuntimeError(
            f"cannot load libEGL ({name}: {error}): the suite renders with EGL (MUJOCO_GL=egl); install your GPU "
            "driver's EGL library or Mesa's (Debian/Ubuntu: apt install libegl1 libgl1-mesa-dri)."
        ) from error
    address = lib.eglGetProcAddress
    address.restype, address.argtypes = ctypes.c_void_p, [ctypes.c_char_p]

    def function(symbol: str, restype, *argtypes):
        pointer = address(symbol.encode())
        if not pointer:
            raise RuntimeError(f"libEGL ({name}) lacks {symbol} (EGL_EXT_device_query): it cannot list its devices, "
                               "so the render device can only be left to dm_control's default.")
        return ctypes.CFUNCTYPE(restype, *argtypes)(pointer)

    query_devices = function("eglQueryDevicesEXT", ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p),
                             ctypes.POINTER(ctypes.c_int))
    query_string = function("eglQueryDeviceStringEXT", ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)
    query_attribute = function("eglQueryDeviceAttribEXT", ctypes.c_uint, ctypes.c_void_p, ctypes.c_int,
                               ctypes.POINTER(ctypes.c_ssize_t))
    return query_devices, query_string, query_attribute


def egl_devices() -> list[EGLDevice]:
    """The machine's EGL devices in ``eglQueryDevicesEXT``'s order (``MUJOCO_EGL_DEVICE_ID``'s index)."""
    query_devices, query_string, query_attribute = _egl()
    handles, count = (ctypes.c_void_p * _MAX_DEVICES)(), ctypes.c_int()
    if query_devices(_MAX_DEVICES, handles, ctypes.byref(count)) != _EGL_TRUE:
        raise RuntimeError("eglQueryDevicesEXT failed: libEGL found no usable driver (is the GPU driver's or Mesa's "
                           "EGL vendor library installed?).")
    devices = []
    for index in range(count.value):
        handle = handles[index]
        extensions = tuple((query_string(handle, _EGL_EXTENSIONS) or b"").decode().split())
        drm = query_string(handle, _EGL_DRM_DEVICE_FILE_EXT)
        cuda = None
        if "EGL_NV_device_cuda" in extensions:
            value = ctypes.c_ssize_t(-1)
            if query_attribute(handle, _EGL_CUDA_DEVICE_NV, ctypes.byref(value)) == _EGL_TRUE and value.value >= 0:
                cuda = int(value.value)  # a GPU hidden by CUDA_VISIBLE_DEVICES answers EGL_FALSE: None
        devices.append(EGLDevice(index, extensions, cuda, drm.decode() if drm else None))
    return devices


def _cuda_ordinal(device: int | str | torch.device) -> int:
    device = torch.device(device) if not isinstance(device, int) else torch.device("cuda", device)
    if device.type != "cuda":
        raise ValueError(f"{device} is not a CUDA device: name cuda, cuda:N or an EGL device index.")
    if device.index is not None:
        return device.index
    return torch.cuda.current_device() if torch.cuda.is_available() else 0


def egl_device_of_cuda(device: int | str | torch.device, devices: list[EGLDevice] | None = None) -> int:
    """The index of the EGL device that is CUDA device ``device`` (``"cuda"``, ``"cuda:1"``, a
    ``torch.device`` or a CUDA ordinal) in this process's CUDA numbering.

    Raises:
        ValueError: no EGL device of this machine says it is that CUDA device (no NVIDIA EGL
            driver, e.g. Mesa only, or the ordinal is out of range), naming the devices there are.
    """
    ordinal = _cuda_ordinal(device)
    devices = egl_devices() if devices is None else devices
    for candidate in devices:
        if candidate.cuda == ordinal:
            return candidate.index
    listed = ", ".join(d.describe() for d in devices) or "none"
    raise ValueError(
        f"no EGL device of this machine is CUDA device {ordinal} (its EGL devices: {listed}). Rendering on a "
        "CUDA GPU needs NVIDIA's EGL driver (EGL_NV_device_cuda) and the GPU visible to CUDA; name an EGL device "
        "index instead, or leave the render device to dm_control's default."
    )


def render_device_index(device: int | str | torch.device, devices: list[EGLDevice] | None = None) -> int:
    """An EGL device index from a render device: an index (int >= 0, checked against the machine's
    devices) as it is, a CUDA device (``"cuda:1"``, ``torch.device``) through :func:`egl_device_of_cuda`."""
    if isinstance(device, bool) or not isinstance(device, (int, str, torch.device)):
        raise TypeError(f"a render device is an EGL device index (int) or a CUDA device ('cuda:N'), got {device!r}.")
    if not isinstance(device, int):
        return egl_device_of_cuda(device, devices)
    devices = egl_devices() if devices is None else devices
    if not 0 <= device < len(devices):
        listed = ", ".join(d.describe() for d in devices) or "none"
        raise ValueError(f"EGL device {device} does not exist: this machine's EGL devices are {listed}.")
    return device


def process_render_device() -> int:
    """The EGL device this process renders on: ``MUJOCO_EGL_DEVICE_ID``, or 0 where unset
    (dm_control then takes the first device that initialises, the first on every machine seen)."""
    value = os.environ.get(EGL_DEVICE_VARIABLE)
    try:
        return 0 if value is None else int(value)
    except ValueError:
        raise ValueError(f"{EGL_DEVICE_VARIABLE}={value!r} is not an EGL device index (an int >= 0).") from None


def render_device_indices(render_devices: Sequence[int | str | torch.device] | None) -> list[int] | None:
    """Worker ``i``'s EGL device is ``result[i % len(result)]``: each of ``render_devices`` (EGL
    indices or CUDA devices, :func:`render_device_index`) checked against the machine's devices
    before any worker starts; ``None`` stays ``None`` (every worker on this process's device)."""
    if render_devices is None:
        return None
    devices = [render_devices] if isinstance(render_devices, (int, str, torch.device)) else list(render_devices)
    if not devices or any(isinstance(d, int) and not isinstance(d, bool) and d < 0 for d in devices):
        raise ValueError(f"render_devices must be a non-empty list of EGL device indices (ints >= 0) or CUDA "
                         f"devices ('cuda:N'), worker i rendering on render_devices[i % len], or None; "
                         f"got {render_devices!r}.")
    machine = egl_devices()
    return [render_device_index(d, machine) for d in devices]


#: Mesa's llvmpipe raster threads per process (0: it renders in the calling thread), read when the
#: process first imports dm_control's EGL renderer (``import dcs_torchrl`` does).
RENDER_THREADS_VARIABLE = "LP_NUM_THREADS"


def render_threads_share(threads: int) -> int | None:
    """``threads`` as the render threads of processes that share the cores, for
    :func:`spawn_environment`; ``None`` (left as it is) where the user's environment sets
    ``LP_NUM_THREADS``."""
    return None if RENDER_THREADS_VARIABLE in os.environ else threads


@contextmanager
def spawn_environment(variables: dict[str, object | None]) -> Iterator[None]:
    """``variables`` (name: value; ``None``: left as it is) in this process's environment for the
    duration, so that a process spawned meanwhile starts with them: the variables a renderer reads
    once, when a process first imports it (``MUJOCO_EGL_DEVICE_ID``, ``LP_NUM_THREADS``), are
    read before any code of a spawned worker runs, since unpickling its function imports
    ``dcs_torchrl``. Setting them inside the worker is too late."""
    before = {name: os.environ.get(name) for name, value in variables.items() if value is not None}
    os.environ.update({name: str(variables[name]) for name in before})
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                del os.environ[name]
            else:
                os.environ[name] = value


def egl_device_environment(device: int | None):
    """``MUJOCO_EGL_DEVICE_ID=device`` in this process's environment for the duration, so that a
    process spawned meanwhile renders on that device (:func:`spawn_environment`). ``None``: the
    environment is left as it is."""
    return spawn_environment({EGL_DEVICE_VARIABLE: device})
