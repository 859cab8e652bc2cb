# shapesearch: the API and the worker share this image (docker-compose.yml runs both).
#   docker build -t shapesearch .                             # meshes and point clouds
#   docker build --build-arg WITH_CAD=true -t shapesearch .   # and STEP/IGES (OpenCascade)
#   docker build --build-arg WITH_MILVUS=true -t shapesearch . # and the Milvus index backend
# Dependencies come from the hash-checked lock files (tools/lock.sh writes them), installed in
# a layer of their own before the source is copied: a code change reinstalls nothing.

# A patch release, not a moving tag; pin its digest too (python:...@sha256:...) where a
# registry can be asked for it.
ARG PYTHON_IMAGE=python:3.11.14-slim-bookworm

FROM ${PYTHON_IMAGE} AS builder
ARG WITH_CAD=false
ARG WITH_MILVUS=false
ENV PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1
RUN python -m venv /venv
# Without CAD the runtime lock; with it the runtime lock plus OpenCascade without VTK
# (cadquery-ocp-novtk: ~380 MB installed, against ~1.3 GB for cadquery-ocp and VTK).
COPY requirements-runtime.lock requirements-cad.lock requirements-milvus.lock /locks/
RUN if [ "$WITH_CAD" = "true" ]; then lock=/locks/requirements-cad.lock; \
    else lock=/locks/requirements-runtime.lock; fi \
    && /venv/bin/pip install --require-hashes --no-deps -r "$lock"
# pymilvus (and milvus-lite) for SHAPESEARCH_INDEX_BACKEND=milvus: the same versions of what
# both locks share, so this adds only the milvus extra's packages.
RUN if [ "$WITH_MILVUS" = "true" ]; then \
        /venv/bin/pip install --require-hashes --no-deps -r /locks/requirements-milvus.lock; fi
# The package as a wheel beside the venv (not into it), so that the final stage's copy of
# the venv stays the same layer when only the code changed.
COPY pyproject.toml README.md /src/
COPY core /src/core
COPY app /src/app
COPY migrations /src/migrations
RUN /venv/bin/pip wheel --no-deps --wheel-dir /wheels /src

FROM ${PYTHON_IMAGE}
ARG WITH_CAD=false
ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    PATH=/venv/bin:$PATH
# OpenCascade's module links libGL and libX11 (nothing is displayed): only with CAD.
RUN if [ "$WITH_CAD" = "true" ]; then \
        apt-get update && apt-get install -y --no-install-recommends libgl1 libx11-6 \
        && rm -rf /var/lib/apt/lists/*; \
    fi
RUN useradd --create-home --uid 10001 shapesearch
COPY --from=builder /venv /venv
COPY --from=builder /wheels /wheels
RUN pip install --no-deps --no-index /wheels/*.whl && rm -rf /wheels

USER shapesearch
WORKDIR /home/shapesearch
# Where the API saves the hub discount's neighbourhoods for its next start (compose mounts a
# volume here, which takes this directory's owner: the unprivileged user can write it).
RUN mkdir index-cache

# In a container the API must listen on all interfaces; keys are then always required
# (create one with: docker compose exec api shapesearch keys create --tenant NAME).
ENV SHAPESEARCH_HOST=0.0.0.0 \
    SHAPESEARCH_REQUIRE_API_KEYS=true
EXPOSE 8000

HEALTHCHECK --interval=10s --timeout=5s --start-period=30s --retries=3 \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=4)"

CMD ["shapesearch", "serve"]
