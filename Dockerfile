# shapesearch: the API and the worker share this image (docker-compose.yml runs both).
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1

# The same install as the README: pip install . from the source tree.
WORKDIR /src
COPY pyproject.toml README.md ./
COPY core ./core
COPY app ./app
COPY migrations ./migrations
# With the cad extra the image reads STEP and IGES (OpenCascade); its VTK dependency links
# libGL and libX11, which the slim image lacks (nothing is displayed).
RUN apt-get update && apt-get install -y --no-install-recommends libgl1 libx11-6 \
    && rm -rf /var/lib/apt/lists/*
RUN pip install '.[cad]' && rm -rf /src

RUN useradd --create-home --uid 10001 shapesearch
USER shapesearch
WORKDIR /home/shapesearch

# In a container the API must listen on all interfaces; keys are then always required
# (create one with: docker compose exec api shapesearch keys create --tenant NAME).
ENV SHAPESEARCH_HOST=0.0.0.0 \
    SHAPESEARCH_REQUIRE_API_KEYS=true
EXPOSE 8000

HEALTHCHECK --interval=10s --timeout=5s --start-period=30s --retries=3 \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=4)"

CMD ["shapesearch", "serve"]
