"""Start-up checks of ``shapesearch serve`` and ``shapesearch worker``.

A wrong setting or an unreachable database is the operator's mistake, not a bug: it gets one
line on stderr that says what is wrong and exit code 2, never a hundred-line traceback.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from pydantic import ValidationError
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError

from app.db.session import make_engine
from app.settings import Settings, engine_settings, variables_of
from core.errors import SettingsError

__all__ = ["StartupError", "checked_settings", "startup_ok"]


class StartupError(Exception):
    """The service cannot start; the message is the one line to print."""


def _first_line(error: BaseException) -> str:
    cause = getattr(error, "orig", None) or error
    lines = [line.strip() for line in str(cause).splitlines() if line.strip()]
    return lines[0] if lines else type(cause).__name__


def _settings() -> Settings:
    """The settings, each valid alone (pydantic) and all of them together (the engine's
    rules, ``core.settings``: checked here so that a wrong combination is one line at
    start-up, not a traceback from the app factory)."""
    try:
        settings = Settings()
    except ValidationError as error:
        problems = "; ".join(
            f"SHAPESEARCH_{'_'.join(str(p) for p in e['loc']).upper()}: {e['msg']}"
            for e in error.errors()
        )
        raise StartupError(f"invalid setting: {problems}") from None
    try:
        engine_settings(settings)
    except SettingsError as error:
        names = ", ".join(variables_of(error))
        raise StartupError(f"invalid setting: {names}: {error.message}") from None
    return settings


def _check_database(url: str) -> None:
    try:
        shown = make_url(url).render_as_string(hide_password=True)
        engine = make_engine(url)
    except (ArgumentError, NoSuchModuleError, ValueError) as error:
        raise StartupError(
            f"SHAPESEARCH_DATABASE_URL is not a usable database URL: {_first_line(error)}"
        ) from None
    try:
        with engine.connect():
            pass
    except (DBAPIError, OSError) as error:
        raise StartupError(f"cannot open the database {shown}: {_first_line(error)}") from None
    finally:
        engine.dispose()


def _prepare_metrics_directory() -> None:
    """A ``PROMETHEUS_MULTIPROC_DIR`` the operator set must exist and be writable before
    prometheus-client writes its first value there (else every process fails at import).
    Checked here, before anything imports prometheus-client (``app.observability.metrics``)."""
    given = os.environ.get("PROMETHEUS_MULTIPROC_DIR")
    if not given:
        return
    directory = Path(given)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise StartupError(
            f"PROMETHEUS_MULTIPROC_DIR={given}: cannot create it: {error.strerror}"
        ) from None
    if not (directory.is_dir() and os.access(directory, os.W_OK | os.X_OK)):
        raise StartupError(f"PROMETHEUS_MULTIPROC_DIR={given}: not a writable directory")


def checked_settings() -> Settings:
    """The settings, once they are valid and the database answers; else ``StartupError``."""
    settings = _settings()
    _check_database(settings.resolved_database_url)
    _prepare_metrics_directory()
    return settings


def startup_ok() -> bool:
    """Run the checks; on failure print the one line to stderr and return False."""
    try:
        checked_settings()
    except StartupError as error:
        print(f"error: {error}", file=sys.stderr)
        return False
    return True
