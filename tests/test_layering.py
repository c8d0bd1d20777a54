"""The distraction base imports nothing about processes or evaluation; the parallel env not the protocol.

Each check imports modules in a fresh interpreter with ``dcs_torchrl``'s ``__init__`` left out
(the package's own ``__init__`` imports everything, ``ParallelSuiteEnv`` included), and reads
``sys.modules`` after: what those modules pull in themselves.
"""
import json
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "dcs_torchrl"

_PROBE = """
import importlib, json, os, sys, types
os.environ.setdefault("MUJOCO_GL", "egl")
package = types.ModuleType("dcs_torchrl")
package.__path__ = [{package!r}]  # the package without its __init__
sys.modules["dcs_torchrl"] = package
for name in {modules!r}:
    importlib.import_module(name)
print(json.dumps(sorted(m for m in sys.modules if m.startswith("dcs_torchrl"))))
"""


def _loaded(modules: list[str]) -> set[str]:
    code = _PROBE.format(package=str(PACKAGE), modules=modules)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    return set(json.loads(out.strip().splitlines()[-1]))


DISTRACTION_BASE = ["dcs_torchrl._scene", "dcs_torchrl.distractions", "dcs_torchrl.distractions.base",
                    "dcs_torchrl.distractions.camera", "dcs_torchrl.distractions.color",
                    "dcs_torchrl.distractions.background", "dcs_torchrl.render"]


def test_the_probe_sees_what_a_module_imports():
    assert {"dcs_torchrl.parallel", "dcs_torchrl._threads"} <= _loaded(["dcs_torchrl.parallel"])


def test_the_distraction_base_imports_no_processes_nor_evaluation():
    loaded = _loaded(DISTRACTION_BASE)
    assert set(DISTRACTION_BASE) <= loaded
    assert not loaded & {"dcs_torchrl.parallel", "dcs_torchrl.evaluation", "dcs_torchrl.process_pool"}


def test_nothing_below_the_envs_imports_the_evaluation_protocol():
    """The envs (one, batched, in processes) and the pool of whole jobs import no evaluation."""
    loaded = _loaded(["dcs_torchrl.envs", "dcs_torchrl.parallel", "dcs_torchrl.batched", "dcs_torchrl.process_pool"])
    assert "dcs_torchrl.evaluation" not in loaded


def test_torch_threads_is_still_the_evaluation_modules():
    from dcs_torchrl import _threads, evaluation

    assert evaluation.torch_threads is _threads.torch_threads
    assert "torch_threads" in evaluation.__all__


def test_the_suites_transforms_still_refuse_a_parallel_suite_env():
    from dcs_torchrl import ParallelSuiteEnv, _scene

    assert getattr(ParallelSuiteEnv, _scene.PHYSICS_ELSEWHERE) is True
