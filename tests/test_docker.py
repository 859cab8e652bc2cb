"""The container files parse and say what the deployment needs (no Docker engine here)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

yaml = pytest.importorskip("yaml")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def compose() -> dict[str, Any]:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_compose_names_the_three_services(compose: dict[str, Any]) -> None:
    assert {"postgres", "api", "worker"} <= set(compose["services"])


def test_api_and_worker_use_the_postgres_service(compose: dict[str, Any]) -> None:
    for name in ("api", "worker"):
        url = compose["services"][name]["environment"]["SHAPESEARCH_DATABASE_URL"]
        assert url.startswith("postgresql+psycopg://") and "@postgres:" in url
        assert "postgres" in compose["services"][name]["depends_on"]


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


def test_dockerfile_installs_the_package_and_runs_unprivileged() -> None:
    lines = [
        line.strip()
        for line in (ROOT / "Dockerfile").read_text().splitlines()
        if line.strip() and not line.lstrip().startswith("#")
    ]
    assert lines[0] == "FROM python:3.11-slim"
    assert any(line.startswith(("RUN pip install .", "RUN pip install '.[cad]'")) for line in lines)
    users = [line.split()[1] for line in lines if line.startswith("USER ")]
    assert users and users[-1] not in ("root", "0")
    assert lines[-1] == 'CMD ["shapesearch", "serve"]'
