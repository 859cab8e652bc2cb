"""The documentation stays a product's: a short README, pages of bounded length, every page
in the site's navigation, and no lab-notebook session ordinals."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).parents[1]
DOCS = ROOT / "docs"

# "the forty-fourth session", "the thirteenth session", "the first session": an ordinal
# (a word, or hyphenated tens and units) right before "session".
_UNITS = "first|second|third|fourth|fifth|sixth|seventh|eighth|ninth"
_TEENS = ("tenth|eleventh|twelfth|thirteenth|fourteenth|fifteenth|sixteenth|seventeenth|"
          "eighteenth|nineteenth")
_TENS = "twenty|thirty|forty|fifty|sixty|seventy|eighty|ninety"
_TENTHS = "twentieth|thirtieth|fortieth|fiftieth|sixtieth|seventieth|eightieth|ninetieth"
SESSION_ORDINAL = re.compile(
    rf"\b(?:{_UNITS}|{_TEENS}|{_TENTHS}|(?:{_TENS})-(?:{_UNITS})|\d+(?:st|nd|rd|th))\s+sessions?\b",
    flags=re.IGNORECASE,
)


class _IgnoreTags(yaml.SafeLoader):
    """A safe loader that reads any ``!!python/...`` tag as null instead of refusing."""


_IgnoreTags.add_multi_constructor("", lambda loader, suffix, node: None)


def nav_pages(entry: Any) -> list[str]:
    """Every page file named in a MkDocs ``nav`` entry (nested sections included)."""
    if isinstance(entry, str):
        return [entry]
    if isinstance(entry, list):
        return [page for item in entry for page in nav_pages(item)]
    if isinstance(entry, dict):
        return [page for value in entry.values() for page in nav_pages(value)]
    return []


def markdown_files() -> list[Path]:
    return sorted(DOCS.rglob("*.md"))


def test_the_readme_is_at_most_400_lines() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").count("\n")
    assert lines <= 400, f"README.md has {lines} lines"


def test_every_page_is_at_most_800_lines() -> None:
    assert markdown_files()
    for page in markdown_files():
        lines = page.read_text(encoding="utf-8").count("\n")
        assert lines <= 800, f"{page.relative_to(ROOT)} has {lines} lines"


def test_every_page_is_in_the_nav_and_every_nav_entry_exists() -> None:
    config = yaml.load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"), Loader=_IgnoreTags)
    assert config["docs_dir"] == "docs"
    nav = nav_pages(config["nav"])
    assert len(nav) == len(set(nav)), "a page is in the nav twice"
    pages = {page.relative_to(DOCS).as_posix() for page in markdown_files()}
    assert set(nav) == pages


def test_no_markdown_mentions_a_session_ordinal() -> None:
    for path in [ROOT / "README.md", ROOT / "CHANGELOG.md", *markdown_files()]:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            assert not SESSION_ORDINAL.search(line), f"{path.relative_to(ROOT)}:{number}: {line}"


def test_the_session_ordinal_pattern_finds_what_it_is_for() -> None:
    for text in ("the forty-fourth session", "in the thirteenth session", "twentieth session",
                 "The first session", "the 21st session", "the eleventh sessions"):
        assert SESSION_ORDINAL.search(text), text
    for text in ("a curl session", "this session", "a session with curl", "forty sessions"):
        assert not SESSION_ORDINAL.search(text), text
