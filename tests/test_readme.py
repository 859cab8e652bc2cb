"""The documentation states every setting with its real default, and the README gives the
commands CI runs (docs that cannot drift)."""

from __future__ import annotations

import re
from pathlib import Path

from app.settings import Settings

ROOT = Path(__file__).parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
CONFIGURATION = (ROOT / "docs" / "configuration.md").read_text(encoding="utf-8")


def documented_defaults() -> dict[str, str]:
    """{setting: default} of every ``| `SHAPESEARCH_NAME` | default |`` row of the
    configuration page."""
    rows = re.findall(
        r"^\| `SHAPESEARCH_([A-Z_]+)` \| ([^|]+) \|", CONFIGURATION, flags=re.MULTILINE
    )
    names = [name for name, _ in rows]
    assert len(names) == len(set(names)), "a setting is documented twice"
    return {name.lower(): default.strip().strip("`") for name, default in rows}


def test_every_setting_is_documented_with_its_default() -> None:
    documented = documented_defaults()
    assert set(documented) == set(Settings.model_fields)
    for name, field in Settings.model_fields.items():
        default = field.default
        if default is None:
            assert documented[name] == "(unset)", name
        elif isinstance(default, float):
            assert float(documented[name]) == default, name
        else:
            assert documented[name] == str(default), name


def test_readme_gives_the_commands_ci_runs() -> None:
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    test_command = (
        "python3 -m venv .venv && .venv/bin/pip install -e '.[test]' && .venv/bin/python -m pytest"
    )
    assert test_command in README and test_command in ci
    serve_command = (
        "python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/shapesearch serve"
    )
    assert serve_command in README
