"""The README and docs/: every relative link reaches a file (and a heading, for `#anchor`s), and the
README opens with the two commands for a fresh machine, the second being what `.ci/run` runs."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^```.*?^```", re.M | re.S)
LINK = re.compile(r"\]\(([^)\s]+)\)")


def heading_anchors(page: Path) -> set[str]:
    """GitHub's anchors for a page's headings: lower case, punctuation dropped, spaces to hyphens,
    `-1`, `-2` ... after repeats."""
    anchors: set[str] = set()
    seen: dict[str, int] = {}
    for heading in re.findall(r"^#{1,6} (.+)$", FENCE.sub("", page.read_text()), re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        anchors.add(f"{slug}-{seen[slug]}" if slug in seen else slug)
        seen[slug] = seen.get(slug, 0) + 1
    return anchors


def relative_links(page: Path) -> list[str]:
    return [t for t in LINK.findall(FENCE.sub("", page.read_text())) if not re.match(r"^[a-z]+:", t)]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(page: Path) -> None:
    broken = []
    for target in relative_links(page):
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in heading_anchors(dest):
            broken.append(f"{target}: no heading with that anchor")
    assert not broken, broken


def test_the_link_check_sees_a_broken_link_and_anchor(tmp_path: Path) -> None:
    (tmp_path / "other.md").write_text("# Other page\n\n## A section: with `code`\n")
    page = tmp_path / "page.md"
    page.write_text("[ok](other.md#a-section-with-code) [gone](missing.md) [bad](other.md#nowhere)\n"
                    "```\n[in code](ignored.md)\n```\n[web](https://example.org)\n")
    assert relative_links(page) == ["other.md#a-section-with-code", "missing.md", "other.md#nowhere"]
    assert heading_anchors(tmp_path / "other.md") == {"other-page", "a-section-with-code"}


def test_the_readme_opens_with_the_two_commands_ci_runs() -> None:
    first_block = FENCE.search((ROOT / "README.md").read_text())
    assert first_block is not None
    commands = first_block.group(0).splitlines()[1:-1]
    assert commands == [
        "tools/setup && .venv/bin/gcs fly --area missions/paper.geojson --sim --speedup 30",
        "tools/setup --test && .venv/bin/python -m pytest -q",
    ]
    ci = (ROOT / ".ci" / "run").read_text()
    assert "phase setup tools/setup --test\n" in ci
    assert re.search(r"^phase tests \.venv/bin/python -m pytest -q( \|\| tests=\$\?)?$", ci, re.MULTILINE)
