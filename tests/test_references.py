"""The project's files cite only what a reader can open: the paper, or a file of this repository.

Every text file of the repository (tracked, or untracked and not ignored) is searched for
references to internal notes that are not part of it; the markdown links of README.md and
docs/ must point to files (and headings) that exist in the repository.
"""
import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# Notes that are not in the repository (written so that this file does not match itself).
NOTES = re.compile(r"\bSPEC(?:\.md\b| ?§| section\b)|\bDESIGN\.md\b", re.IGNORECASE)
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|//)", re.IGNORECASE)  # http:, https:, mailto:, ...


def _repository_files() -> list[str]:
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
                             cwd=ROOT, check=True, capture_output=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the repository's file list is unknown")
    return sorted({name for name in out.decode("utf-8").split("\0") if name and (ROOT / name).is_file()})


FILES = _repository_files() if (ROOT / ".git").exists() else []
DIRECTORIES = {str(Path(name).parents[i]) for name in FILES for i in range(len(Path(name).parents) - 1)}
MARKDOWN = [name for name in FILES if name == "README.md" or (name.startswith("docs/") and name.endswith(".md"))]


def _text(name: str) -> str | None:
    data = (ROOT / name).read_bytes()
    if b"\0" in data[:8192]:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


def _slug(heading: str) -> str:
    """GitHub's anchor for a markdown heading."""
    text = re.sub(r"[`*_]|\[([^\]]*)\]\([^)]*\)", lambda m: m.group(1) or "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _anchors(text: str) -> set[str]:
    seen: dict[str, int] = {}
    anchors = set()
    for heading in re.findall(r"^#{1,6}\s+(.+?)\s*#*\s*$", _without_fences(text), flags=re.MULTILINE):
        slug = _slug(heading)
        n = seen.get(slug, 0)
        anchors.add(slug if n == 0 else f"{slug}-{n}")
        seen[slug] = n + 1
    return anchors


def _without_fences(text: str) -> str:
    """The text without fenced code blocks."""
    return re.sub(r"^```.*?^```[^\n]*$", "", text, flags=re.MULTILINE | re.DOTALL)


def _outside_code(text: str) -> str:
    """The text without fenced code blocks and inline code spans."""
    return re.sub(r"`[^`\n]*`", "", _without_fences(text))


def test_the_patterns_find_what_they_should():
    assert NOTES.search("see " + "SPEC" + " §5.3")
    assert NOTES.search("(" + "SPEC" + "§1.1)")
    assert NOTES.search("SPEC" + " section 3")
    assert NOTES.search("SPEC" + ".md and " + "DESIGN" + ".md")
    assert not NOTES.search("ACTION_SPEC = Bounded(...); the spec's bounds; a TensorSpec")
    assert [m.group(1) for m in LINK.finditer("[a](docs/x.md#y) ![b](img.png) [c](https://e.org)")] == [
        "docs/x.md#y", "img.png", "https://e.org"]
    assert _slug("Camera pose (Sec. 3.1)") == "camera-pose-sec-31"
    assert _slug("Experiment 1 at CPU scale (`budget=cpu`): three SAC+RAD seeds") == (
        "experiment-1-at-cpu-scale-budgetcpu-three-sacrad-seeds")
    assert _slug("Where the loop's time goes") == "where-the-loops-time-goes"


def test_the_file_list_holds_the_project():
    assert {"README.md", "pyproject.toml", "tests/test_references.py"} <= set(FILES)


@pytest.mark.parametrize("name", FILES)
def test_no_reference_to_notes_outside_the_repository(name):
    text = _text(name)
    if text is None:
        return
    found = [f"{i}: {line.strip()[:120]}" for i, line in enumerate(text.splitlines(), 1) if NOTES.search(line)]
    assert found == [], "cite the paper (docs/paper.md says how) or a page of docs/ instead"


@pytest.mark.parametrize("name", MARKDOWN)
def test_markdown_links_resolve(name):
    text = _text(name) or ""
    here = Path(name).parent
    broken = []
    for match in LINK.finditer(_outside_code(text)):
        target = match.group(1)
        if EXTERNAL.match(target):
            continue
        path, _, anchor = target.partition("#")
        if path:
            resolved = os.path.normpath(os.path.join(here, path)).replace(os.sep, "/")
            if resolved not in FILES and resolved not in DIRECTORIES:
                broken.append(f"{target}: no such file or directory in the repository")
                continue
        else:
            resolved = name
        if anchor and resolved.endswith(".md") and resolved in FILES:
            if anchor not in _anchors(_text(resolved) or ""):
                broken.append(f"{target}: no heading with anchor #{anchor} in {resolved}")
    assert broken == []
