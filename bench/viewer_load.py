"""Benchmark: how fast the viewer's model page shows a part with a 2000-point preview.

Starts ``shapesearch serve`` (temporary SQLite database, max_points 4000 so that the stored
preview holds its full 2000 points), uploads two parts, then loads the model page of one of
them in Debian's Chromium (Playwright, fresh browser context each time, so no cache) and
reads when the first 3D frame was drawn (``performance.now()`` since navigation start, set
by the renderer). Baseline in the same run: the catalogue page until its table is filled.

Usage::

    nice -n 10 .venv/bin/python bench/viewer_load.py [--runs 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

from live_server import live_server  # noqa: E402
from test_browser import CHROMIUM, CHROMIUM_ARGS  # noqa: E402

PARTS = REPO / "tests" / "fixtures" / "parts"


def upload_and_wait(url: str, names: list[str]) -> list[str]:
    ids = []
    for name in names:
        response = httpx.post(
            f"{url}/v1/models", files={"file": (name, (PARTS / name).read_bytes())}
        )
        response.raise_for_status()
        ids.append(response.json()["id"])
    deadline = time.monotonic() + 300
    while any(httpx.get(f"{url}/v1/models/{i}").json()["status"] != "ready" for i in ids):
        if time.monotonic() > deadline:
            raise SystemExit("models not ready in time")
        time.sleep(0.5)
    return ids


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()

    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as data, live_server(
        Path(data), {"SHAPESEARCH_MAX_POINTS": "4000"}
    ) as url:
        model_id, _ = upload_and_wait(url, ["angle_block.STL", "cylinder.stl"])
        preview = httpx.get(f"{url}/v1/models/{model_id}/preview").content
        n_points = int.from_bytes(preview[4:8], "little")
        page_ms, catalogue_ms = [], []
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS
            )
            for _ in range(args.runs):
                context = browser.new_context(viewport={"width": 1280, "height": 900})
                page = context.new_page()
                page.goto(f"{url}/#/models/{model_id}")
                page.wait_for_selector("canvas.view[data-rendered]")
                page_ms.append(
                    page.evaluate("() => +document.querySelector('canvas.view').dataset.rendered")
                )
                context.close()
                context = browser.new_context(viewport={"width": 1280, "height": 900})
                page = context.new_page()
                page.goto(f"{url}/")
                page.wait_for_selector("#models tr")
                catalogue_ms.append(page.evaluate("() => performance.now()"))
                context.close()
            browser.close()

    page_median = statistics.median(page_ms)
    catalogue_median = statistics.median(catalogue_ms)
    print(f"preview: {n_points} points, {len(preview)} bytes")
    print(f"model page, navigation -> first 3D frame: median {page_median:.0f} ms "
          f"(runs: {', '.join(f'{v:.0f}' for v in page_ms)})")
    print(f"baseline, catalogue page -> table filled: median {catalogue_median:.0f} ms")
    print(f"ratio model page / catalogue: {page_median / catalogue_median:.2f}")


if __name__ == "__main__":
    main()
