"""Where the service runs: its database, the addresses it binds, and how many processes and
threads serve."""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import BaseModel, Field, ValidationInfo, field_validator
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError

__all__ = ["DatabaseSettings", "ServerSettings"]


class DatabaseSettings(BaseModel):
    """The database, and the data directory that holds the embedded one."""

    database_url: str | None = Field(
        default=None,
        description="SQLAlchemy URL of the database, e.g. postgresql+psycopg://user@host/db. "
        "Unset: a SQLite file shapesearch.db in the data directory (embedded mode).",
    )
    database_password_file: Path | None = Field(
        default=None,
        description="File holding the database password (a Docker or Compose secret, e.g. "
        "/run/secrets/postgres_password): it takes the place of any password in "
        "SHAPESEARCH_DATABASE_URL, so that no environment variable holds it. Trailing "
        "newlines are not part of it. Unset: the URL's own.",
    )
    data_dir: Path = Field(
        default=Path("data"), description="Directory for the embedded SQLite database."
    )

    @field_validator("database_password_file")
    @classmethod
    def _password_file_usable(cls, path: Path | None, info: ValidationInfo) -> Path | None:
        """A password file needs a server URL to go into and a password in it."""
        if path is None:
            return None
        url = info.data.get("database_url")
        if not url:
            raise ValueError("needs SHAPESEARCH_DATABASE_URL (an embedded SQLite database "
                             "has no password)")
        try:
            make_url(url)
        except ArgumentError:
            raise ValueError("SHAPESEARCH_DATABASE_URL is not a database URL") from None
        _read_password(path)
        return path

    @property
    def resolved_database_url(self) -> str:
        """The database URL with the password file's password, defaulting to the embedded
        SQLite file."""
        if self.database_url and self.database_password_file is not None:
            password = _read_password(self.database_password_file)
            url = make_url(self.database_url).set(password=password)
            return url.render_as_string(hide_password=False)
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'shapesearch.db').as_posix()}"


class ServerSettings(BaseModel):
    """The addresses `shapesearch serve` binds, its processes and threads, and who may call it
    from a browser."""

    host: str = Field(
        default="127.0.0.1",
        description="Address `shapesearch serve` binds, and `shapesearch worker` for its "
        "metrics port.",
    )
    port: int = Field(default=8000, ge=1, le=65535, description="Port `shapesearch serve` binds.")
    api_processes: int = Field(
        default=1,
        ge=1,
        description="API processes `shapesearch serve` runs on its port (Linux: each has a "
        "socket of its own, SO_REUSEPORT). Each holds its own index and follows the change "
        "feed; the embedded worker's threads are shared out among them. Two on two cores "
        "served 1.6x the similar requests of one (docs/operations.md, Scale-out).",
    )
    query_threads: int = Field(
        default=4,
        ge=1,
        description="Threads of an API process that run similarity queries (database and "
        "index); more concurrent requests wait in line for them. With several API processes "
        "one each does best (docs/operations.md, Scale-out).",
    )
    workers: int | None = Field(
        default=None,
        ge=0,
        description="Worker threads of `serve` (embedded; 0: none) or processes of "
        "`shapesearch worker`. Unset: one per core (each describe pins BLAS to one thread).",
    )
    cors_origins: str = Field(
        default="",
        description="Origins (comma-separated, e.g. https://plm.example.com) whose web pages "
        "may call the API from a browser (CORS); empty: none.",
    )

    @property
    def cors_origin_list(self) -> list[str]:
        """``cors_origins`` as a list (blank entries dropped)."""
        return [origin.strip() for origin in self.cors_origins.split(",") if origin.strip()]

    @property
    def worker_count(self) -> int:
        """Describes run at once: ``workers``, or one per core when unset. Processes
        (``shapesearch worker``) scale better than the embedded worker's threads, part of a
        describe holding the GIL (docs/benchmarks.md, "Describing a part")."""
        return self.workers if self.workers is not None else (os.cpu_count() or 1)


def _read_password(path: Path) -> str:
    """The password in ``path``, without the trailing newlines (as the PostgreSQL image
    reads its POSTGRES_PASSWORD_FILE); ``ValueError`` when unreadable or empty."""
    try:
        password = path.read_text(encoding="utf-8").rstrip("\n")
    except (OSError, UnicodeDecodeError) as error:
        reason = getattr(error, "strerror", None) or str(error)
        raise ValueError(f"cannot read {path}: {reason}") from None
    if not password:
        raise ValueError(f"{path} holds no password")
    return password
