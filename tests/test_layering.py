"""The distraction base imports nothing about processes or evaluation; the parallel env not the protocol.

Each check imports modules in a fresh interpreter with ``dcs_torchrl``'s ``__init__`` left out
(the package's own ``__init__`` imports everything, ``ParallelSuiteEnv`` included), and reads
``sys.modules`` after: what those modules pull in themselves. Imports inside functions, which no
import runs, are read from the source.
"""
import ast
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
                    "dcs_torchrl.distractions.background", "dcs_torchrl.render.gl"]


def test_the_probe_sees_what_a_module_imports():
    assert {"dcs_torchrl.vector.parallel", "dcs_torchrl.vector._threads"} <= _loaded(["dcs_torchrl.vector.parallel"])


def test_the_distraction_base_imports_no_processes_nor_evaluation():
    loaded = _loaded(DISTRACTION_BASE)
    assert set(DISTRACTION_BASE) <= loaded
    assert not loaded & {"dcs_torchrl.vector.parallel", "dcs_torchrl.evaluation.protocol", "dcs_torchrl.vector.process_pool"}


def test_nothing_below_the_envs_imports_the_evaluation_protocol():
    """The envs (one, batched, in processes) and the pool of whole jobs import no evaluation."""
    loaded = _loaded(["dcs_torchrl.envs", "dcs_torchrl.vector.parallel", "dcs_torchrl.vector.batched", "dcs_torchrl.vector.process_pool"])
    assert "dcs_torchrl.evaluation.protocol" not in loaded


#: The package's rooms, lowest first: a room's modules, once imported, have loaded nothing of a room
#: above it (imports inside functions, e.g. ``make_env(num_envs=N)`` building a batch, are calls upward
#: at run time, not at import). docs/architecture.md draws the same order.
ROOMS = {
    "compat": ["dcs_torchrl._compat", "dcs_torchrl._compat.private_api", "dcs_torchrl._compat.judged_warnings"],
    "render": ["dcs_torchrl.presets", "dcs_torchrl._scene", "dcs_torchrl.render", "dcs_torchrl.render.warp",
               "dcs_torchrl.render.egl_devices"],
    "distractions": ["dcs_torchrl.distractions", "dcs_torchrl.videos", "dcs_torchrl.textures"],
    "envs": ["dcs_torchrl.envs"],
    "vector": ["dcs_torchrl.vector", "dcs_torchrl.vector.batched", "dcs_torchrl.vector.parallel",
               "dcs_torchrl.vector.process_pool"],
    "agents": ["dcs_torchrl.methods", "dcs_torchrl.results", "dcs_torchrl.modules", "dcs_torchrl.objectives"],
    "evaluation": ["dcs_torchrl.evaluation.protocol", "dcs_torchrl.evaluation"],
    # loading agents (their checkpoints, their training's pixel envs) and evaluating many settings of them
    # are jobs on training's run directories
    "jobs": ["dcs_torchrl.algorithms", "dcs_torchrl.training", "dcs_torchrl.pretrained", "dcs_torchrl.evaluation.scheduling",
             "dcs_torchrl.datasets", "dcs_torchrl.experiments", "dcs_torchrl.report", "dcs_torchrl.robustness",
             "dcs_torchrl.gym_env", "dcs_torchrl.gallery"],
}

#: Imports inside functions that reach a room above, each a door a user opens at run time: ``make_env(num_envs=N)``
#: builds N envs (``vector``) from the envs room's one entry point.
DOORS = {("dcs_torchrl.envs", "vector")}


def _room_of(module: str) -> str | None:
    """The room of the longest entry of :data:`ROOMS` that ``module`` is or lies under."""
    best = max(((len(m), room) for room, modules in ROOMS.items() for m in modules
                if module == m or module.startswith(m + ".")), default=None)
    return None if best is None else best[1]


def _module_of(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports_in_functions(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` of each import of the package inside a function (or method) of ``path``."""
    module, tree = _module_of(path), ast.parse(path.read_text())
    found = []
    for function in ast.walk(tree):
        if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(function):
            if isinstance(node, ast.Import):
                found += [(node.lineno, alias.name) for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:  # relative: from the package the module is in
                    package = module.split(".")[: len(module.split(".")) - node.level + (path.name == "__init__.py")]
                    base = ".".join(package + ([node.module] if node.module else []))
                found += [(node.lineno, f"{base}.{alias.name}") for alias in node.names]
    return [(line, name) for line, name in found if name.startswith("dcs_torchrl.")]


def test_each_room_imports_nothing_from_the_rooms_above_it():
    from concurrent.futures import ThreadPoolExecutor

    order = list(ROOMS)
    with ThreadPoolExecutor(len(order)) as pool:  # a fresh interpreter each, all at once
        loaded = dict(zip(order[:-1], pool.map(_loaded, [ROOMS[room] for room in order[:-1]])))
    for i, room in enumerate(order[:-1]):
        above = set(order[i + 1:])
        upward = sorted(m for m in loaded[room] if _room_of(m) in above)
        assert not upward, f"importing the {room} room loads {upward}, of rooms above it"


def test_imports_inside_functions_keep_to_the_rooms_too():
    """An import run only when a function is called is a dependency all the same: none reaches a room above
    its module's, but for the :data:`DOORS` (a cycle through rooms otherwise hides from the import probe)."""
    order = list(ROOMS)
    upward = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = _module_of(path)
        room = _room_of(module)
        for line, name in _imports_in_functions(path):
            target = _room_of(name)
            if target is not None and order.index(target) > order.index(room) and (module, target) not in DOORS:
                upward.append(f"{module}:{line} ({room}) imports {name} ({target})")
    assert not upward, upward


def test_every_module_of_the_package_has_a_room():
    files = (p.relative_to(PACKAGE.parent).with_suffix("").parts for p in PACKAGE.rglob("*.py"))
    modules = {".".join(parts[:-1] if parts[-1] == "__init__" else parts) for parts in files} - {"dcs_torchrl"}
    assert not sorted(m for m in modules if _room_of(m) is None), "a module in no room of ROOMS"


def test_torch_threads_is_still_the_evaluation_modules():
    from dcs_torchrl import evaluation
    from dcs_torchrl.vector import _threads

    assert evaluation.torch_threads is _threads.torch_threads
    assert "torch_threads" in evaluation.__all__


def test_the_suites_transforms_still_refuse_a_parallel_suite_env():
    from dcs_torchrl import ParallelSuiteEnv, _scene

    assert getattr(ParallelSuiteEnv, _scene.PHYSICS_ELSEWHERE) is True
