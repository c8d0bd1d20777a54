"""What the render of a distracted camera pose costs, the scene and everything else unchanged.

    python benchmarks/pose_render.py cheetah run [--benchmark medium] [--poses 12] [--renders 240]

One undistracted env (default profile) renders the same physics state alternately from the
task's own camera pose and from ``--poses`` camera poses of ``--benchmark`` (static camera
distraction only, one pose per seeded reset of a second env, written into ``data.cam_xpos`` /
``cam_xmat`` before each render), ``--renders`` renders each, alternating so that machine noise
hits both alike. Repeated with MuJoCo's shadows, reflections or skybox switched off (the scene's
``mjRND_*`` flags), to show which part of the render the pose changes. Only the render is clocked
(dm_control's ``Camera.render``: scene update, ``mjr_render``, ``mjr_readPixels``); no
distraction runs in the clocked env, so the difference is the render of another view of the same
scene, which belongs to the benchmark's camera ranges (Stone et al. 2021, Sec. 3.1), not to the suite's work.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import torch  # noqa: E402
from distraction_cost import renderer_of  # noqa: E402  (benchmarks/ is the script's directory)
from loop_speed import cpu_model  # noqa: E402

import dcs_torchrl as dcs  # noqa: E402
from dcs_torchrl._scene import locate  # noqa: E402

FLAGS = mujoco.mjtRndFlag
SWITCHES = {  # scene flags set for each row; the others stay on
    "everything on": {},
    "shadows off": {FLAGS.mjRND_SHADOW: 0},
    "reflections off": {FLAGS.mjRND_REFLECTION: 0},
    "skybox off": {FLAGS.mjRND_SKYBOX: 0},
}


def distracted_poses(domain: str, task: str, benchmark: str, count: int) -> list[tuple]:
    """``(cam_xpos, cam_xmat)`` of the rendered camera after ``count`` seeded resets of a static env
    with only the benchmark's camera distraction (no colours, no videos)."""
    env = dcs.make_env(domain, task, benchmark=benchmark, dynamic=False, seed=0, color_scale=0.0, num_videos=0)
    physics, camera_id = reset_renderer(env)[1:]
    poses = []
    for seed in range(count):
        env.set_seed(seed)
        env.reset()
        poses.append((physics.data.cam_xpos[camera_id].copy(), physics.data.cam_xmat[camera_id].copy()))
    env.close()
    return poses


def reset_renderer(env):
    """Resets a suite env; its RenderPixels, physics and the camera it renders."""
    env.reset()
    renderer = renderer_of(env)
    scene = locate(renderer, strict=True)
    return renderer, scene.physics, renderer._resolved_camera(scene)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("domain")
    parser.add_argument("task")
    parser.add_argument("--benchmark", default="medium", choices=[b for b in dcs.BENCHMARKS if b != "none"])
    parser.add_argument("--poses", type=int, default=12)
    parser.add_argument("--renders", type=int, default=240)
    args = parser.parse_args()
    if args.poses < 1 or args.renders < 1:
        parser.error("--poses and --renders must be at least 1")
    torch.set_num_threads(1)
    poses = distracted_poses(args.domain, args.task, args.benchmark, args.poses)
    env = dcs.make_env(args.domain, args.task, seed=0)
    renderer, physics, camera_id = reset_renderer(env)
    camera = renderer.__dict__["_camera"]
    own = (physics.data.cam_xpos[camera_id].copy(), physics.data.cam_xmat[camera_id].copy())
    flags = camera._scene.flags

    def render_from(pose) -> float:
        physics.data.cam_xpos[camera_id], physics.data.cam_xmat[camera_id] = pose
        start = time.perf_counter()
        camera.render()
        return time.perf_counter() - start

    print(f"{args.domain} {args.task}, default profile, {cpu_model()}; "
          f"{args.renders} renders from the task's camera and {args.renders} from {args.poses} {args.benchmark} "
          "poses, alternating; medians, ms")
    print(f"| scene | task's camera | {args.benchmark} poses | difference |")
    print("|---|---:|---:|---:|")
    defaults = {flag: int(flags[flag]) for switch in SWITCHES.values() for flag in switch}
    for name, switch in SWITCHES.items():
        for flag, value in {**defaults, **switch}.items():
            flags[flag] = value
        own_times, moved_times = [], []
        for i in range(args.renders):
            own_times.append(render_from(own))
            moved_times.append(render_from(poses[i % len(poses)]))
        a, b = 1e3 * statistics.median(own_times), 1e3 * statistics.median(moved_times)
        print(f"| {name} | {a:.2f} | {b:.2f} | {b - a:+.3f} ({100 * (b / a - 1):+.1f}%) |")
    for flag, value in defaults.items():
        flags[flag] = value
    env.close()


if __name__ == "__main__":
    main()
