"""benchmarks/renderer_scores.py: the shipped agents' clean scores on this machine's renderer, per render profile."""
import re
import sys
from pathlib import Path

import pytest
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from renderer_scores import main  # noqa: E402

from dcs_torchrl.pretrained import load_pretrained  # noqa: E402

AGENT = "sac_rad_cartpole_swingup"


@pytest.mark.slow  # the benchmark script's own run (episodes of the shipped agent); the profiles' pixels: test_render.py
def test_rows_are_the_agents_own_evaluation_and_the_profiles_render_apart(capsys):
    main(["--episodes", "1", "--agents", AGENT, "--profiles", "default", "fast"])
    out = capsys.readouterr().out
    assert re.search(r"^\S.* / .*; .*; 1 episodes a row", out)  # the GL vendor / renderer, the CPU
    rows = dict(re.findall(rf"^\| {AGENT} \| (\w+) \| ([\d.]+) ± [\d.]+ \| [0-9a-f]{{12}} \|$", out, re.M))
    assert set(rows) == {"default", "fast"}
    agent = load_pretrained(AGENT)
    assert float(rows["default"]) == round(agent.evaluate(1).mean, 1)  # the robustness command's clean point
    digests = re.findall(r"\| ([0-9a-f]{12}) \|$", out, re.M)
    assert digests[0] != digests[1]  # the profiles' pixels differ ...
    frames = []
    for profile in ("default", "fast"):
        env = agent.make_env(seed=agent.eval_seed, render_profile=profile)
        frames.append(env.reset()["pixels"].to(torch.int16))
        env.close()
    assert (frames[0] - frames[1]).abs().float().mean() < 1.0  # ... by less than a grey level on average
