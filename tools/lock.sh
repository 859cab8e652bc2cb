#!/usr/bin/env bash
# Regenerate the lock files from pyproject.toml, for Python 3.11 on Linux x86_64 (the image's
# and CI's platform), with the hash of every file: run it after changing a dependency.
#   requirements-runtime.lock  the runtime dependencies (the image without CAD)
#   requirements.lock          runtime + the test extra (CI, and developers' venvs)
#   requirements-cad.lock      runtime + the cad-novtk extra (the image built with WITH_CAD=true)
#   requirements-milvus.lock   runtime + the milvus extra (SHAPESEARCH_INDEX_BACKEND=milvus)
# Each later file is constrained by the one before, so a package shared by two locks has the
# same version in both: the image runs what CI tested. Needs uv (pip install uv).
# Upgrading numpy, scipy, trimesh, robust-laplacian or qdldl changes descriptor_version:
# every stored model then needs `shapesearch redescribe`.
set -euo pipefail
cd "$(dirname "$0")/.."
uv="${UV:-$(command -v uv || echo .venv/bin/uv)}"
compile=("$uv" pip compile pyproject.toml --quiet --generate-hashes --python-version 3.11
         --python-platform x86_64-manylinux_2_28 --custom-compile-command tools/lock.sh "$@")
"${compile[@]}" -o requirements-runtime.lock
"${compile[@]}" --extra test -c requirements-runtime.lock -o requirements.lock
"${compile[@]}" --extra cad-novtk -c requirements.lock -o requirements-cad.lock
"${compile[@]}" --extra milvus -c requirements.lock -o requirements-milvus.lock
