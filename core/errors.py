"""The exceptions raised by the engine.

One hierarchy, documented once (in the manner of httpx):

    ShapeSearchError            anything the engine raises on purpose
    ├── InvalidShapeError       the input can never be described (bad file, bad geometry);
    │                           retrying will not help, the message tells the user what to fix
    ├── SolverError             a numerical step failed on acceptable input; may be transient
    └── SettingsError           engine settings that cannot work together (also a ValueError);
                                ``fields`` names the settings involved

Every refusal of user input is an ``InvalidShapeError`` with a short machine-readable
``reason`` code and a human-readable message. An ``OSError`` whose ``errno`` is one of
``NO_SPACE_ERRNOS`` (a full disk under a reader's temporary copy) is the machine's, not the
file's: it is never turned into a refusal.
"""

from __future__ import annotations

import errno

__all__ = [
    "NO_SPACE_ERRNOS", "InvalidShapeError", "SettingsError", "ShapeSearchError", "SolverError",
]

#: ``OSError.errno`` values of a full disk or an exhausted quota.
NO_SPACE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})


class ShapeSearchError(Exception):
    """Base class of every error the engine raises on purpose."""


class InvalidShapeError(ShapeSearchError):
    """The input cannot be described; the message says why and what to do.

    Parameters
    ----------
    reason : str
        Machine-readable code, one of ``REASONS``.
    message : str
        Sentence a user can act on.
    """

    REASONS = (
        "empty_file",
        "unknown_format",
        "unparsable",
        "non_finite",
        "too_few_points",
        "degenerate",
        "too_large",
        "cad_unavailable",
        "assembly_too_large",
    )

    def __init__(self, reason: str, message: str) -> None:
        if reason not in self.REASONS:
            raise ValueError(f"unknown reason {reason!r}")
        super().__init__(message)
        self.reason = reason
        self.message = message


class SolverError(ShapeSearchError):
    """A numerical step (factorisation, eigen-solve) failed on acceptable input."""


class SettingsError(ShapeSearchError, ValueError):
    """Engine settings that are invalid alone or together.

    Parameters
    ----------
    message : str
        What is wrong, in terms of the settings.
    *fields : str
        The settings involved, as dotted paths in ``EngineSettings`` (``"cutoff.n_min"``),
        so that a front end can name its own variables for them.
    """

    def __init__(self, message: str, *fields: str) -> None:
        super().__init__(message)
        self.message = message
        self.fields = fields

    def within(self, section: str) -> SettingsError:
        """The same error with its fields prefixed by ``section.``."""
        return SettingsError(self.message, *(f"{section}.{name}" for name in self.fields))
