"""conftest.py: without an optional extra (Gymnasium, as on a bare GPU box) the suite still runs,
leaves out the modules that need it, and says so in its header."""
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_without_gymnasium_its_modules_are_left_out_and_named(tmp_path):
    hidden = tmp_path / "gymnasium"
    hidden.mkdir()
    (hidden / "__init__.py").write_text("raise ModuleNotFoundError(\"No module named 'gymnasium'\", name='gymnasium')\n")
    # in front of what PYTHONPATH holds already (a GPU box puts its unpacked wheels there)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH")]))}
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", "tests", "dcs_torchrl"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "gymnasium is not installed: not collected: tests/test_gymnasium.py, dcs_torchrl/gym_env.py" in done.stdout
    collected = [line for line in done.stdout.splitlines() if "::" in line]
    assert len(collected) > 1000
    assert not any(line.startswith(("tests/test_gymnasium.py::", "dcs_torchrl/gym_env.py::")) for line in collected)


def test_without_mujoco_warp_the_warp_backend_names_its_extra(tmp_path):
    hidden = tmp_path / "mujoco_warp"
    hidden.mkdir()
    (hidden / "__init__.py").write_text("raise ModuleNotFoundError(\"No module named 'mujoco_warp'\", name='mujoco_warp')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH")]))}
    code = ("import dcs_torchrl as dcs\n"
            "dcs.make_env('cartpole', 'swingup').reset()  # the GL backend needs nothing more\n"
            "try:\n    dcs.make_env('cartpole', 'swingup', num_envs=2, backend='warp')\n"
            "except ImportError as error:\n    print('refused:', error)\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert 'refused: backend="warp" needs MuJoCo Warp: pip install "dcs-torchrl[warp]"' in done.stdout
