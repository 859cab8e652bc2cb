"""The README documents every setting with its real default (docs that cannot drift)."""

from __future__ import annotations

import re
from pathlib import Path

from app.settings import Settings

README = (Path(__file__).parents[1] / "README.md").read_text(encoding="utf-8")


def documented_defaults() -> dict[str, str]:
    rows = re.findall(r"^\| `SHAPESEARCH_([A-Z_]+)` \| ([^|]+) \|", README, flags=re.MULTILINE)
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
    ci = (Path(__file__).parents[1] / ".ci" / "run").read_text(encoding="utf-8")
    test_command = (
        "python3 -m venv .venv && .venv/bin/pip install -e '.[test]' && .venv/bin/python -m pytest"
    )
    assert test_command in README and test_command in ci
    serve_command = (
        "python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/shapesearch serve"
    )
    assert serve_command in README
