"""Every relative link in the README, the CHANGELOG and docs/ reaches a file, and every ``#anchor`` into a
Markdown page a heading of it (GitHub's slugs): rows moved to docs/performance/history.md had kept their
``performance/`` prefix and led nowhere."""

from __future__ import annotations

import re
from pathlib import Path

import masonry

ROOT = Path(masonry.__file__).resolve().parent.parent.parent
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"#{1,6} (.*)")


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation but ``-`` and ``_`` dropped, spaces to ``-``."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _prose(path: Path) -> list[tuple[int, str]]:
    """The page's lines outside fenced code blocks, numbered from 1."""
    lines, fenced = [], False
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced:
            lines.append((number, line))
    return lines


def _anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out: set[str] = set()
    for _, line in _prose(path):
        if match := HEADING.match(line):
            slug = _slug(match.group(1))
            count = seen.get(slug, 0)
            seen[slug] = count + 1
            out.add(slug if count == 0 else f"{slug}-{count}")
    return out


def _cached(anchors: dict[Path, set[str]], page: Path) -> set[str]:
    if page not in anchors:
        anchors[page] = _anchors(page)
    return anchors[page]


def _broken(root: Path) -> list[str]:
    pages = [root / "README.md", root / "CHANGELOG.md", *sorted((root / "docs").rglob("*.md"))]
    anchors: dict[Path, set[str]] = {}
    broken = []
    for page in pages:
        for number, line in _prose(page):
            for target in LINK.findall(line):
                if re.match(r"[a-z]+:", target):
                    continue  # a URL (https:, mailto:) is not ours to check offline
                path, _, fragment = target.partition("#")
                linked = page.parent / path if path else page
                where = f"{page.relative_to(root)}:{number}: {target}"
                if not linked.exists():
                    broken.append(f"{where} (no such file)")
                elif fragment and linked.suffix == ".md" and fragment not in _cached(anchors, linked):
                    broken.append(f"{where} (no such heading)")
    return broken


def test_every_relative_link_in_the_docs_leads_somewhere() -> None:
    assert (ROOT / "docs" / "performance.md").exists(), (
        "the docs were not found: the scan would check nothing"
    )
    broken = _broken(ROOT)
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_the_scan_finds_a_missing_file_and_a_missing_heading(tmp_path: Path) -> None:
    (tmp_path / "docs" / "sub").mkdir(parents=True)
    (tmp_path / "README.md").write_text(
        "# Top\n[ok](docs/a.md#a-b-c) [gone](docs/none.md)\n", encoding="utf-8"
    )
    (tmp_path / "CHANGELOG.md").write_text("```\n[in code](nowhere.md)\n```\n", encoding="utf-8")
    (tmp_path / "docs" / "a.md").write_text("## A (b) c\n[self](#a-b-c) [bad](#d)\n", encoding="utf-8")
    (tmp_path / "docs" / "sub" / "b.md").write_text(
        "[up](a.md)\n[url](https://example.org/x)\n", encoding="utf-8"
    )
    assert _broken(tmp_path) == [
        "README.md:2: docs/none.md (no such file)",
        "docs/a.md:2: #d (no such heading)",
        "docs/sub/b.md:1: a.md (no such file)",
    ]
