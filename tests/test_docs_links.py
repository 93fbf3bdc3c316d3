"""Every relative link of the README and docs/ leads somewhere: the file exists and, for a
``#fragment``, one of its headings has that anchor (GitHub's rule: lower case, punctuation
other than ``-`` and ``_`` dropped, spaces to hyphens)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([ROOT / "README.md", *ROOT.glob("docs/*.md"), *ROOT.glob("examples/*/README.md")])
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
CODE_BLOCK = re.compile(r"^```.*?^```", re.S | re.M)


def anchors(page: Path) -> set[str]:
    """The anchors of a page's headings (duplicates numbered as GitHub numbers them)."""
    seen: dict[str, int] = {}
    out = set()
    for line in CODE_BLOCK.sub("", page.read_text()).splitlines():
        if not line.startswith("#"):
            continue
        text = line.lstrip("#").strip().lower()
        slug = re.sub(r"[^\w\- ]", "", text).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        out.add(slug if count == 0 else f"{slug}-{count}")
    return out


def links(page: Path):
    for target in LINK.findall(CODE_BLOCK.sub("", page.read_text())):
        if not re.match(r"^[a-z]+:", target):        # http:, https:, mailto:
            yield target


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page):
    broken = []
    for target in links(page):
        path, _, fragment = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists():
            broken.append(f"{target}: no such file")
        elif fragment and file.suffix == ".md" and fragment not in anchors(file):
            broken.append(f"{target}: no heading with that anchor")
    assert not broken, f"{page.relative_to(ROOT)}: " + "; ".join(broken)


def test_the_readme_fits_two_screens_and_starts_with_its_two_commands():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) < 200
    blocks = re.findall(r"```bash\n(.*?)```", text, re.S)
    assert "pip install -e . && mitsuba-refs compare cornell-box" in blocks[0]
    assert 'pip install -e ".[test]" && pytest -q' in blocks[1]
