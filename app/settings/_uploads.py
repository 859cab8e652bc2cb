"""Uploads and their limits: what an upload may be, how it is checked at the door, how long
its describe may take, and how long a request's Idempotency-Key is remembered."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

__all__ = ["MIB", "UploadSettings"]

MIB = 1024 * 1024


class UploadSettings(BaseModel):
    """The limits of uploads and of the child process that describes them."""

    max_upload_bytes: int = Field(
        default=64 * MIB, ge=1, description="Largest accepted upload in bytes (larger: 413)."
    )
    upload_check_points: int = Field(
        default=2000,
        ge=10,
        description="Points sampled when an upload is parsed at once to reject bad files "
        "with 422 (the full description runs later in a worker).",
    )
    upload_check_timeout_seconds: float = Field(
        default=10.0,
        gt=0,
        description="Time an upload's sandboxed quick check (STEP, IGES, GLB, glTF, 3MF, LAZ, E57 "
        "and files over 256 KiB) may take, waiting for a free check slot included; past it the "
        "upload is accepted unchecked and its describe in the worker decides.",
    )
    upload_check_max_concurrent: int = Field(
        default=2,
        ge=1,
        description="Sandboxed quick checks one API process runs at once (each a child that "
        "may take SHAPESEARCH_DESCRIBE_MEMORY_BYTES); more uploads wait for a slot.",
    )
    max_text_length: int = Field(
        default=500,
        ge=1,
        le=10000,
        description="Longest external_id, name, filename or query parameter, in characters "
        "(longer: 422). Text must be valid UTF-8 without NUL characters.",
    )
    max_metadata_bytes: int = Field(
        default=16384,
        ge=2,
        description="Largest metadata object, in bytes of compact JSON (larger: 422).",
    )
    max_metadata_depth: int = Field(
        default=8,
        ge=1,
        le=100,
        description="Deepest nesting of objects and arrays in metadata, the top object "
        "counting as 1 (deeper: 422). Numbers must be finite.",
    )
    describe_memory_bytes: int = Field(
        default=4 * 1024 * MIB,
        ge=64 * MIB,
        description="Address space the child process that parses and describes each file may "
        "take beyond its start (its RLIMIT_AS is its start plus this); above it the file is "
        "refused as too large (413 or a failed job).",
    )
    describe_timeout_seconds: float = Field(
        default=300.0,
        gt=0,
        description="Wall-clock limit of that child process for the largest files; a file "
        "that takes longer than its limit is refused as too large.",
    )
    describe_timeout_base_seconds: float = Field(
        default=60.0,
        gt=0,
        description="The limit of a small file: a file of S MB may take this plus "
        "describe_timeout_seconds_per_mb times S, at most describe_timeout_seconds (a reader "
        "that hangs on a small corrupt file is stopped in a minute, not five).",
    )
    describe_timeout_seconds_per_mb: float = Field(
        default=10.0,
        ge=0,
        description="What each MB of a file adds to its limit (valid mesh and cloud files "
        "of 6 MB and more needed at most 1.1 s a MB, bench/describe_by_size.py).",
    )
    assembly_default: Literal["whole", "split"] = Field(
        default="whole",
        description="What an upload without the assembly field is: whole (one model) or "
        "split (a GLB, glTF, 3MF, OBJ, STEP or IGES file that places more than one part "
        "becomes the assembly's model and a model per distinct part, as with "
        "assembly=split; a file of one part stays one model).",
    )
    assembly_max_parts: int = Field(
        default=500,
        ge=1,
        le=5000,
        description="Most distinct parts an assembly split on upload may have (more: 422 "
        "assembly-too-large); each part is then described with the usual limits.",
    )
    idempotency_ttl_seconds: float = Field(
        default=86400.0,
        gt=0,
        description="Seconds an Idempotency-Key is remembered; a retry after that is a new "
        "request (expired keys are deleted as new ones are stored).",
    )
