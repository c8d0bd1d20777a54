"""Committed docs and data name no directory of the machine that produced them."""
import re
import tarfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# An absolute path into a machine's own directories (not a placeholder such as ~/data or <dir>).
MACHINE_PATH = re.compile(r"(?<![\w.~/-])/(?:work|tmp|home|root|Users|mnt|scratch|private|var/folders)/[\w.-]")
TEXT = (".md", ".csv", ".json", ".yaml", ".yml", ".txt", ".cff")
FILES = sorted(
    [ROOT / "README.md"]
    + [p for p in (ROOT / "docs").rglob("*") if p.suffix in TEXT]
    + [p for p in (ROOT / "dcs_torchrl").rglob("*") if p.suffix in (".json", ".csv", ".md", ".yaml")]
    + [p for p in (ROOT / "recipes").rglob("*") if p.suffix in TEXT]
)
# archives of records committed under docs/ (the report's results.tar.gz): every text member
ARCHIVES = sorted((ROOT / "docs").rglob("*.tar.gz"))


def test_the_pattern_finds_machine_paths_and_spares_placeholders():
    assert MACHINE_PATH.search("Results directory: `/work/runs/smoke`")
    assert MACHINE_PATH.search("source: paper; /tmp/x.tex")
    assert not MACHINE_PATH.search("background_dir=~/data/DAVIS, root=<dir>, runs/smoke, ../runs/smoke")


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_machine_paths_in_committed_text(path):
    lines = path.read_text(encoding="utf-8").splitlines()
    found = [f"{i}: {line.strip()[:100]}" for i, line in enumerate(lines, 1) if MACHINE_PATH.search(line)]
    assert found == []


def test_every_committed_record_is_searched():
    names = {p.relative_to(ROOT).as_posix() for p in FILES}
    assert any(n.startswith("docs/experiments/") and n.endswith(".json") for n in names)  # the robustness points
    assert any(n.startswith("recipes/pretrained/") and n.endswith(".json") for n in names)  # the shipped agents


@pytest.mark.parametrize("path", ARCHIVES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_machine_paths_in_committed_archives(path):
    found = []
    with tarfile.open(path) as archive:
        for member in archive:
            if not member.isfile():
                continue
            text = archive.extractfile(member).read().decode("utf-8", errors="replace")
            found += [f"{member.name}:{i}" for i, line in enumerate(text.splitlines(), 1) if MACHINE_PATH.search(line)]
    assert found == []
