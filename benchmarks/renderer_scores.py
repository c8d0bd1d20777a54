"""The shipped agents' clean scores on this machine's renderer, with each render profile.

    python benchmarks/renderer_scores.py [--episodes 20] [--profiles default fast] [--agents NAME ...]

Two OpenGL implementations (Mesa's llvmpipe on a CPU, NVIDIA's driver on a GPU) rasterise the
same scene into slightly different pixels, and an agent trained on one sees the other's as a
small distraction. This prints, per shipped agent and render profile, the mean ± standard error
of ``--episodes`` deterministic episodes in the agent's training env with the seeds of its final
evaluation (the robustness command's clean point), and a digest of the first frame, beside the
GL renderer's name: run it on two machines and compare (docs/results.md, "Renderer dependence").
"""
from __future__ import annotations

import argparse
import hashlib
import os

os.environ.setdefault("MUJOCO_GL", "egl")

from machine import cpu_model  # noqa: E402


def gl_renderer() -> str:
    """``GL_VENDOR`` / ``GL_RENDERER`` of the context dm_control renders with in this process."""
    from dm_control import mujoco
    from OpenGL import GL

    physics = mujoco.Physics.from_xml_string("<mujoco/>")
    with physics.contexts.gl.make_current() as ctx:
        vendor, renderer = ctx.call(lambda: (GL.glGetString(GL.GL_VENDOR), GL.glGetString(GL.GL_RENDERER)))
    physics.free()
    return f"{vendor.decode()} / {renderer.decode()}"


def clean_score(name: str, profile: str, episodes: int, device: str) -> tuple[float, float, str]:
    """(mean, standard error, SHA-256 of the first frame's bytes, 12 hex digits)."""
    from dcs_torchrl.evaluation.protocol import evaluate
    from dcs_torchrl.pretrained import load_pretrained

    agent = load_pretrained(name, device)
    env = agent.make_env(seed=agent.eval_seed, render_profile=profile)
    try:
        first = env.reset()["pixels"].numpy().tobytes()
        result = evaluate(env, agent.policy, episodes, seed=agent.eval_seed)
    finally:
        env.close()
    return result.mean, result.stderr, hashlib.sha256(first).hexdigest()[:12]


def main(argv=None):
    from dcs_torchrl.pretrained import shipped_agents

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--profiles", nargs="+", default=["default", "fast"])
    parser.add_argument("--agents", nargs="+", default=sorted(shipped_agents()))
    parser.add_argument("--device", default="cpu", help="where the policy acts (cpu, cuda)")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error("--episodes must be >= 1")
    print(f"{gl_renderer()}; {cpu_model()}; {args.episodes} episodes a row, the seeds of each agent's final evaluation")
    print("| agent | render profile | clean return | first frame (SHA-256) |\n|---|---|---:|---|")
    for name in args.agents:
        for profile in args.profiles:
            mean, stderr, digest = clean_score(name, profile, args.episodes, args.device)
            print(f"| {name} | {profile} | {mean:.1f} ± {stderr:.1f} | {digest} |", flush=True)


if __name__ == "__main__":
    main()
