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
