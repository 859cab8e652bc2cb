"""What routes need from the app: its services, a database session."""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Annotated

from fastapi import Depends, Request
from sqlalchemy import Engine
from sqlalchemy.orm import Session, sessionmaker

from app.api.uploads import UploadReader
from app.ingest.describing import descriptor_version
from app.search.comparing import Comparer
from app.search.index import ShapeIndex
from app.settings import Settings
from core.settings import EngineSettings

__all__ = ["ServicesDep", "Services", "SessionDep", "get_services", "get_session"]


@dataclass
class Services:
    """Everything one app instance owns; created by its lifespan, kept on ``app.state``."""

    settings: Settings
    engine_settings: EngineSettings
    engine: Engine
    sessions: sessionmaker[Session]
    reader: Engine  # hot read-only paths (app.db.session.read_only)
    queries: ThreadPoolExecutor  # similarity queries (app.api.routes.models.similar_models)
    index: ShapeIndex
    uploads: UploadReader  # reads and quick-checks uploaded files (app.api.uploads)
    # Comparisons of two parts and search explanations: slots and cache (app.search.comparing)
    comparer: Comparer = field(default_factory=Comparer)

    @property
    def descriptor_version(self) -> str:
        """The descriptor_version this service's engine settings produce."""
        return descriptor_version(self.engine_settings)


async def get_services(request: Request) -> Services:
    # async: FastAPI runs a plain ``def`` dependency in its thread pool, a thread hop per
    # request for a dictionary lookup.
    return request.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]


def get_session(services: ServicesDep) -> Iterator[Session]:
    with services.sessions() as session:
        yield session


SessionDep = Annotated[Session, Depends(get_session)]
