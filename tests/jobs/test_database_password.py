"""SHAPESEARCH_DATABASE_PASSWORD_FILE: the database password from a secret file (the
Compose deployment's), never from an environment variable."""

from __future__ import annotations

from pathlib import Path

import pytest
from sqlalchemy.engine import make_url

from app.settings import Settings
from app.startup import StartupError, checked_settings

URL = "postgresql+psycopg://shapesearch@postgres:5432/shapesearch"


def test_the_file_s_password_goes_into_the_url(tmp_path: Path) -> None:
    secret = tmp_path / "postgres_password"
    # Characters that mean something in a URL, and the newline an editor leaves at the end.
    secret.write_text("p@ss:w/rd?#%\n")
    for url in (URL, URL.replace("shapesearch@", "shapesearch:old@")):
        resolved = make_url(Settings(database_url=url, database_password_file=secret)
                            .resolved_database_url)
        assert resolved.password == "p@ss:w/rd?#%"
        assert (resolved.username, resolved.host, resolved.port, resolved.database) == (
            "shapesearch", "postgres", 5432, "shapesearch")


def test_without_the_file_the_url_is_as_given() -> None:
    assert Settings(database_url=URL).resolved_database_url == URL


@pytest.mark.parametrize(
    ("content", "url", "reason"),
    [
        (None, URL, "cannot read"),
        ("\n", URL, "holds no password"),
        ("secret", None, "needs SHAPESEARCH_DATABASE_URL"),
    ],
)
def test_an_unusable_password_file_is_one_line_at_start_up(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    content: str | None, url: str | None, reason: str,
) -> None:
    secret = tmp_path / "postgres_password"
    if content is not None:
        secret.write_text(content)
    monkeypatch.setenv("SHAPESEARCH_DATABASE_PASSWORD_FILE", str(secret))
    monkeypatch.setenv("SHAPESEARCH_DATA_DIR", str(tmp_path))
    if url is None:
        monkeypatch.delenv("SHAPESEARCH_DATABASE_URL", raising=False)
    else:
        monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", url)
    with pytest.raises(StartupError) as refused:
        checked_settings()
    message = str(refused.value)
    assert message.startswith("invalid setting: SHAPESEARCH_DATABASE_PASSWORD_FILE: ")
    assert reason in message and "\n" not in message
