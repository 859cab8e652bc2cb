"""The lock files (tools/lock.sh writes them) pin what pyproject.toml asks for, agree with each
other, and CI installs from one of them."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
PIN = re.compile(r"^([A-Za-z0-9._-]+)==(\S+) \\$")

# Each lock and the pyproject requirements it covers.
LOCKS = {
    "requirements-runtime.lock": (),
    "requirements.lock": ("test",),
    "requirements-cad.lock": ("cad-novtk",),
    "requirements-milvus.lock": ("milvus",),
}


def pins(name: str) -> dict[str, str]:
    """The lock's ``package: version``; every pin must carry a hash on its next line."""
    lines = (ROOT / name).read_text().splitlines()
    found: dict[str, str] = {}
    for number, line in enumerate(lines):
        match = PIN.match(line)
        if match:
            assert lines[number + 1].strip().startswith("--hash=sha256:"), line
            found[canonicalize_name(match[1])] = match[2]
    return found


def requirements(extras: tuple[str, ...]) -> list[Requirement]:
    asked = list(PROJECT["dependencies"])
    for extra in extras:
        asked += PROJECT["optional-dependencies"][extra]
    return [Requirement(text) for text in asked]


@pytest.mark.parametrize(("name", "extras"), LOCKS.items())
def test_a_lock_pins_every_requirement_at_an_allowed_version(
    name: str, extras: tuple[str, ...]
) -> None:
    pinned = pins(name)
    for requirement in requirements(extras):
        version = pinned.get(canonicalize_name(requirement.name))
        assert version is not None, f"{name} lacks {requirement}: run tools/lock.sh"
        assert requirement.specifier.contains(version, prereleases=True), (
            f"{name} pins {requirement.name}=={version}, pyproject asks {requirement}"
        )


def test_the_locks_agree_and_the_runtime_lock_holds_no_test_tools() -> None:
    locks = {name: pins(name) for name in LOCKS}
    everything: dict[str, str] = {}
    for name, pinned in locks.items():
        for package, version in pinned.items():
            assert everything.setdefault(package, version) == version, (
                f"{package} is {version} in {name}, {everything[package]} in another lock"
            )
    assert not {"pytest", "ruff", "vtk"} & set(locks["requirements-runtime.lock"])
    # The image's OpenCascade is the one the tests run, without VTK.
    assert "vtk" not in locks["requirements-cad.lock"]
    assert (locks["requirements-cad.lock"]["cadquery-ocp-novtk"]
            == locks["requirements.lock"]["cadquery-ocp"])


def test_ci_installs_the_lock_before_the_readme_command() -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    lock = ci.index(".venv/bin/pip install --require-hashes -r requirements.lock")
    assert lock < ci.index(".venv/bin/pip install -e '.[test]'")
