"""The documentation: README.md is the user guide (≤ 9 KB), the status page ≤ 8 KB, every relative link
in README.md
and docs/ resolves (file, and heading when the link has one), benchmark reports are dated."""

import re
import unicodedata
from pathlib import Path

import pytest

from tests.helpers import ROOT

README_LIMIT = 9216  # bytes
STATUS_LIMIT = 8192  # bytes: one short verdict per row, the measurements in the reports
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.DOTALL | re.MULTILINE)
CODE_SPAN = re.compile(r"(`+).+?\1", re.DOTALL)


def _prose(text: str) -> str:
    """The text without fenced code blocks and code spans (links there are not links)."""
    return CODE_SPAN.sub("", FENCE.sub("", text))


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading).strip().lower()
    kept = "".join(c for c in text if c in " -_" or unicodedata.category(c)[0] in "LN")
    return kept.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    anchors = set()
    for line in FENCE.sub("", path.read_text(encoding="utf-8")).splitlines():
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            slug = _slug(m.group(1))
            n = seen.get(slug, 0)
            seen[slug] = n + 1
            anchors.add(slug if n == 0 else f"{slug}-{n}")
    return anchors


def _links(path: Path) -> list[str]:
    return LINK.findall(_prose(path.read_text(encoding="utf-8")))


def test_status_page_is_at_most_8_kb():
    size = (ROOT / "docs" / "status.md").stat().st_size
    assert size <= STATUS_LIMIT, (
        f"docs/status.md is {size} bytes (limit {STATUS_LIMIT}): one verdict per row, the "
        "numbers in the dated report it links")


def test_readme_is_at_most_9_kb():
    size = (ROOT / "README.md").stat().st_size
    assert size <= README_LIMIT, (
        f"README.md is {size} bytes (limit {README_LIMIT}): equations go in docs/model.md, "
        "measurements in dated reports under docs/benchmarks/")


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    broken = []
    for target in _links(doc):
        if re.match(r"[a-z][a-z0-9+.-]*:", target, re.IGNORECASE):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        dest = (doc.parent / file_part).resolve() if file_part else doc
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            broken.append(f"{target}: no heading #{anchor} in {dest.name}")
    assert not broken, f"{doc.relative_to(ROOT)}: " + "; ".join(broken)


def test_link_checker_sees_links_and_anchors():
    """The checker itself: it finds links outside code and GitHub's heading anchors."""
    text = "[a](x.md) `[b](y.md)`\n```\n[c](z.md)\n```\n![d](img.png \"t\")"
    assert LINK.findall(_prose(text)) == ["x.md", "img.png"]
    assert _slug("Time stepping and the regularized solver") == (
        "time-stepping-and-the-regularized-solver")
    assert _slug("`scene` with `kind: layer` — μ(I)") == "scene-with-kind-layer--μi"
    assert _links(ROOT / "README.md"), "no links found in README.md"


def test_benchmark_reports_are_dated_and_indexed():
    folder = ROOT / "docs" / "benchmarks"
    index = (folder / "README.md").read_text(encoding="utf-8")
    reports = sorted(p.name for p in folder.glob("*.md") if p.name != "README.md")
    assert reports
    for name in reports:
        assert re.fullmatch(r"\d{4}-\d{2}-\d{2}-[a-z0-9-]+\.md", name), name
        assert f"]({name})" in index, f"{name} is not listed in docs/benchmarks/README.md"
