"""The container files parse and say what the deployment needs (no Docker engine here)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy.engine import make_url

yaml = pytest.importorskip("yaml")

ROOT = Path(__file__).resolve().parents[1]
SECRETS = "/run/secrets/"


@pytest.fixture(scope="module")
def compose() -> dict[str, Any]:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def dockerfile_stages() -> list[list[str]]:
    """The Dockerfile's instructions (continuation lines joined, comments dropped), one
    list per stage; the first list holds what comes before the first FROM."""
    text = re.sub(r"\\\n\s*", " ", (ROOT / "Dockerfile").read_text())
    lines = [line.strip() for line in text.splitlines()]
    stages: list[list[str]] = [[]]
    for line in lines:
        if not line or line.startswith("#"):
            continue
        if line.startswith("FROM "):
            stages.append([])
        stages[-1].append(line)
    return stages


def test_compose_names_the_three_services(compose: dict[str, Any]) -> None:
    assert {"postgres", "api", "worker"} <= set(compose["services"])


def test_api_and_worker_use_the_postgres_service(compose: dict[str, Any]) -> None:
    for name in ("api", "worker"):
        url = compose["services"][name]["environment"]["SHAPESEARCH_DATABASE_URL"]
        assert url.startswith("postgresql+psycopg://") and "@postgres:" in url
        assert "postgres" in compose["services"][name]["depends_on"]


def test_the_database_password_is_a_secret_file_only(compose: dict[str, Any]) -> None:
    # The secret comes from the operator's environment (.env), not from this file.
    secret = compose["secrets"]["postgres_password"]
    assert secret == {"environment": "POSTGRES_PASSWORD"}
    postgres = compose["services"]["postgres"]
    assert "POSTGRES_PASSWORD" not in postgres["environment"]
    assert postgres["environment"]["POSTGRES_PASSWORD_FILE"] == SECRETS + "postgres_password"
    assert "postgres_password" in postgres["secrets"]
    for name in ("api", "worker"):
        service = compose["services"][name]
        environment = service["environment"]
        assert make_url(environment["SHAPESEARCH_DATABASE_URL"]).password is None
        assert environment["SHAPESEARCH_DATABASE_PASSWORD_FILE"] == SECRETS + "postgres_password"
        assert "postgres_password" in service["secrets"]
    for name, service in compose["services"].items():
        for key in service.get("environment", {}):
            assert not key.endswith("PASSWORD"), f"{name} has a password variable {key}"


def test_the_password_s_env_file_is_documented_and_never_shipped() -> None:
    example = dict(
        line.split("=", 1) for line in (ROOT / ".env.example").read_text().splitlines()
        if line and not line.startswith("#")
    )
    assert example["POSTGRES_PASSWORD"] == ""  # the operator chooses it
    assert ".env" in (ROOT / ".gitignore").read_text().split()
    assert ".env" in (ROOT / ".dockerignore").read_text().split()


def test_workers_can_be_scaled(compose: dict[str, Any]) -> None:
    worker = compose["services"]["worker"]
    assert "container_name" not in worker and "ports" not in worker
    assert worker["command"][:2] == ["shapesearch", "worker"]
    assert compose["services"]["api"]["command"] == ["shapesearch", "serve", "--no-worker"]


def test_workers_serve_metrics_where_the_readme_scrapes_them(compose: dict[str, Any]) -> None:
    environment = compose["services"]["worker"]["environment"]
    port = environment["SHAPESEARCH_WORKER_METRICS_PORT"]
    # Not loopback: a Prometheus container on the compose network must reach every replica.
    assert environment["SHAPESEARCH_HOST"] == "0.0.0.0"
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert f"`worker:{port}/metrics`" in readme and f"port: {port}" in readme
    assert f"worker:{port}/metrics" in (ROOT / "docker-compose.yml").read_text()


def test_every_service_has_a_healthcheck(compose: dict[str, Any]) -> None:
    for name, service in compose["services"].items():
        assert service.get("healthcheck", {}).get("test"), f"{name} has no healthcheck"


def test_the_database_lives_on_a_volume(compose: dict[str, Any]) -> None:
    volumes = compose["services"]["postgres"]["volumes"]
    named = [v.split(":")[0] for v in volumes]
    assert any(v in compose.get("volumes", {}) for v in named)
    assert any(v.endswith("/var/lib/postgresql/data") for v in volumes)


def test_the_api_s_index_cache_lives_on_a_volume_its_user_can_write(
    compose: dict[str, Any],
) -> None:
    api = compose["services"]["api"]
    cache = api["environment"]["SHAPESEARCH_INDEX_CACHE_DIR"]
    (volume,) = [v.split(":")[0] for v in api["volumes"] if v.endswith(":" + cache)]
    assert volume in compose["volumes"]
    # Made by the unprivileged user in the image: a named volume mounted there takes its
    # owner (one Docker creates where nothing is would be root's).
    _, _, final = dockerfile_stages()
    workdir = [line.split()[1] for line in final if line.startswith("WORKDIR ")][-1]
    made = final.index(f"RUN mkdir {Path(cache).relative_to(workdir)}")
    assert made > max(i for i, line in enumerate(final) if line.startswith("USER "))


def test_the_base_image_is_a_pinned_patch_release() -> None:
    preamble, *stages = dockerfile_stages()
    (argument,) = [line for line in preamble if line.startswith("ARG PYTHON_IMAGE=")]
    image = argument.split("=", 1)[1]
    assert re.fullmatch(r"python:3\.11\.\d+-slim-bookworm(@sha256:[0-9a-f]{64})?", image)
    assert [stage[0].split()[1] for stage in stages] == ["${PYTHON_IMAGE}"] * 2


def test_dependencies_install_from_the_lock_before_the_source_is_copied() -> None:
    _, builder, _ = dockerfile_stages()
    copies = [i for i, line in enumerate(builder) if line.startswith("COPY ")]
    installs = [i for i, line in enumerate(builder) if "pip install --require-hashes" in line]
    locks = [i for i in copies if ".lock" in builder[i]]
    sources = [i for i in copies if re.search(r"\b(core|app|migrations|pyproject\.toml)\b",
                                              builder[i])]
    assert locks and installs and sources
    assert max(locks) < min(installs) < min(sources)
    assert "requirements-runtime.lock" in builder[installs[0]]
    assert "requirements-cad.lock" in builder[installs[0]]


def test_the_final_stage_copies_the_venv_and_runs_unprivileged() -> None:
    _, _, final = dockerfile_stages()
    assert any(line.startswith("COPY --from=builder /venv /venv") for line in final)
    assert any("pip install --no-deps --no-index /wheels/" in line for line in final)
    users = [line.split()[1] for line in final if line.startswith("USER ")]
    assert users and users[-1] not in ("root", "0")
    assert final[-1] == 'CMD ["shapesearch", "serve"]'


def test_cad_is_a_build_argument_and_brings_its_libraries_only_then() -> None:
    _, builder, final = dockerfile_stages()
    for stage in (builder, final):
        assert "ARG WITH_CAD=false" in stage
    apt = [line for line in final if "apt-get install" in line]
    assert len(apt) == 1 and apt[0].startswith('RUN if [ "$WITH_CAD" = "true" ]; then')
    assert "libgl1" in apt[0] and "libx11-6" in apt[0]
    assert not any("apt-get" in line for line in builder)
