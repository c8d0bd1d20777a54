"""Which GPU renders: the machine's EGL devices as libEGL lists them, and the EGL device of a CUDA device.

The machine's own list is queried for real (Mesa's software device here; NVIDIA's devices on a GPU
box). The CUDA mapping is tested on a list shaped like an NVIDIA node's, where the EGL order is
not the CUDA order and Mesa's device comes first.
"""
import pytest
import torch

from dcs_torchrl.render.egl_devices import EGLDevice, egl_device_of_cuda, egl_devices, process_render_device, render_device_index

#: A node whose EGL order differs from its CUDA order: Mesa's device first, then CUDA 1, then CUDA 0,
#: then a GPU that CUDA_VISIBLE_DEVICES hides (its driver gives no CUDA ordinal).
NODE = [
    EGLDevice(0, ("EGL_MESA_device_software", "EGL_EXT_device_drm_render_node"), None, None),
    EGLDevice(1, ("EGL_NV_device_cuda", "EGL_EXT_device_drm"), 1, "/dev/dri/card1"),
    EGLDevice(2, ("EGL_NV_device_cuda", "EGL_EXT_device_drm"), 0, "/dev/dri/card0"),
    EGLDevice(3, ("EGL_NV_device_cuda", "EGL_EXT_device_drm"), None, "/dev/dri/card2"),
]


def test_this_machine_lists_its_egl_devices_in_order():
    devices = egl_devices()
    assert devices and [d.index for d in devices] == list(range(len(devices)))
    assert all(isinstance(d.extensions, tuple) and all(isinstance(e, str) for e in d.extensions) for d in devices)
    # a device that is not NVIDIA's names no CUDA ordinal; an NVIDIA one names a distinct one
    cuda = [d.cuda for d in devices if d.cuda is not None]
    assert all("EGL_NV_device_cuda" in d.extensions for d in devices if d.cuda is not None)
    assert len(cuda) == len(set(cuda))
    assert egl_devices() == devices  # the same answer each time


def test_a_cuda_device_maps_to_the_egl_device_its_driver_names():
    assert egl_device_of_cuda("cuda:0", NODE) == 2
    assert egl_device_of_cuda("cuda:1", NODE) == 1
    assert egl_device_of_cuda(torch.device("cuda", 1), NODE) == 1
    assert egl_device_of_cuda(0, NODE) == 2  # a CUDA ordinal
    assert render_device_index("cuda:1", NODE) == 1
    assert render_device_index(3, NODE) == 3  # an EGL index is taken as it is
    assert NODE[2].describe() == "2 (CUDA device 0, /dev/dri/card0)"
    assert NODE[0].describe() == "0 (software: EGL_MESA_device_software)"


def test_devices_that_do_not_exist_are_refused_naming_the_machines_devices():
    with pytest.raises(ValueError, match=r"no EGL device of this machine is CUDA device 2 \(its EGL devices: 0 \(software"):
        egl_device_of_cuda("cuda:2", NODE)
    with pytest.raises(ValueError, match=r"EGL device 4 does not exist: this machine's EGL devices are 0 .*3 \(no CUDA device"):
        render_device_index(4, NODE)
    with pytest.raises(ValueError, match="cpu is not a CUDA device"):
        render_device_index("cpu", NODE)
    with pytest.raises(TypeError, match="a render device is an EGL device index"):
        render_device_index(True, NODE)
    if not any(d.cuda is not None for d in egl_devices()):  # Mesa only: no GPU renders for CUDA
        with pytest.raises(ValueError, match="needs NVIDIA's EGL driver"):
            egl_device_of_cuda("cuda:0")


def test_the_process_device_is_the_variable_dm_control_reads(monkeypatch):
    monkeypatch.delenv("MUJOCO_EGL_DEVICE_ID", raising=False)
    assert process_render_device() == 0
    monkeypatch.setenv("MUJOCO_EGL_DEVICE_ID", "2")
    assert process_render_device() == 2
    monkeypatch.setenv("MUJOCO_EGL_DEVICE_ID", "gpu0")
    with pytest.raises(ValueError, match="MUJOCO_EGL_DEVICE_ID='gpu0' is not an EGL device index"):
        process_render_device()
