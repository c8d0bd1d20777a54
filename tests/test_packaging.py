"""pyproject.toml lists every package of dcs_torchrl, and ships recipes/pretrained inside it."""
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_is_listed_and_the_shipped_agents_are_mapped():
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = [p for p in (ROOT / "dcs_torchrl").rglob("*") if p.is_dir() and p.name != "__pycache__"]
    found = {".".join(p.relative_to(ROOT).parts) for p in [ROOT / "dcs_torchrl", *folders]}  # packages and data
    assert set(setuptools["packages"]) == found | {"dcs_torchrl.shipped_agents"}
    assert setuptools["package-dir"] == {"dcs_torchrl.shipped_agents": "recipes/pretrained"}
    assert (ROOT / "recipes/pretrained/sac_rad_cartpole_swingup/results.json").is_file()
