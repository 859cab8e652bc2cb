"""The viewer's assembly pages (issue 76) in headless Chromium: an assembly uploaded with
assembly=split lists its parts with their counts and a preview of each, and highlights a part
in the assembly's view; a part's page links back to the assembly under "Used in". Skips
without a browser, as the other browser tests do."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.assembly_files import assembly_glb
from tests.browser.test_browser import (
    CHROMIUM,
    CHROMIUM_ARGS,
    Offline,
    _browser_missing,
)
from tests.live_server import live_server


@pytest.mark.slow
def test_an_assembly_page_lists_its_parts_and_a_part_page_its_assembly(
    tmp_path: Path,
) -> None:
    missing = _browser_missing()
    if missing is not None:
        pytest.skip(f"browser tests skipped: {missing}")
    from playwright.sync_api import sync_playwright

    with live_server(tmp_path) as url:
        response = httpx.post(f"{url}/v1/models", data={"assembly": "split", "name": "frame"},
                              files={"file": ("frame.glb", assembly_glb())})
        assert response.status_code == 202, response.text
        assembly_id = response.json()["id"]
        parts = httpx.get(f"{url}/v1/models/{assembly_id}/parts").json()["parts"]
        part_a = next(part["model"]["id"] for part in parts if part["count"] == 4)
        deadline = time.monotonic() + 300
        for model_id in [assembly_id, *(part["model"]["id"] for part in parts)]:
            while httpx.get(f"{url}/v1/models/{model_id}").json()["status"] != "ready":
                assert time.monotonic() < deadline
                time.sleep(0.2)
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True,
                                                 args=CHROMIUM_ARGS)
            page: Any = browser.new_page()
            page.set_default_timeout(30_000)
            offline = Offline(page)
            page.goto(f"{url}/#/models/{assembly_id}")
            page.wait_for_selector("#parts li")
            items = page.locator("#parts li")
            assert items.count() == 2
            assert sorted(text.rsplit(" ", 1)[-1] for text in items.all_inner_texts()) == [
                "1", "4"]
            assert page.locator("#parts li canvas.thumb").count() == 2
            page.click(f"#parts li[data-model-id='{part_a}'] button.show")
            view = page.locator(f"canvas.view[data-highlighted='{part_a}']")
            view.wait_for()
            shown = int(view.get_attribute("data-highlighted-points") or 0)
            total = len(httpx.get(f"{url}/v1/models/{assembly_id}/parts/points").json()["labels"])
            assert 0 < shown < total  # A's points, not the pin's
            page.click(f"#parts li[data-model-id='{part_a}'] a")
            page.wait_for_selector("#used-in li")
            used = page.locator("#used-in li")
            assert used.count() == 1
            assert used.first.get_attribute("data-model-id") == assembly_id
            assert "\u00d7 4" in used.first.inner_text()
            assert offline.blocked == [] and offline.errors == []
            browser.close()
