"""Rendering the distracted scene: GL (:mod:`.gl`, one env, EGL), MuJoCo Warp (:mod:`.warp`, N worlds
in one call), the skybox both read (:mod:`.skybox`) and the EGL devices GL renders on
(:mod:`.egl_devices`). The GL transform and its profiles are importable from here."""
from dcs_torchrl.render.gl import PROFILES, RenderPixels, RenderProfile, check_profile, render_context

__all__ = ["PROFILES", "RenderPixels", "RenderProfile", "check_profile", "render_context"]
