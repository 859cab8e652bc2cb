"""The viewer and the API docs in a real browser: Debian's Chromium driven by Playwright.

Every request to anything but 127.0.0.1 is blocked and recorded: the pages must render
fully offline. Screenshots go to tests/artifacts/ (kept by CI as artefacts, git-ignored).
Without a browser the tests skip, except on CI (CI=true), where that is a failure.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import httpx
import pytest

from tests.conftest import PARTS
from tests.live_server import live_server

# A browser, a live server and real describes: seconds a test.
pytestmark = pytest.mark.slow

ARTIFACTS = Path(__file__).parents[1] / "artifacts"
SCAN = Path(__file__).parents[1] / "fixtures" / "scans" / "angle_block_scan.ply"
CHROMIUM = os.environ.get("SHAPESEARCH_TEST_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    # WebGL without a GPU: Chromium's software renderer, which it no longer picks on its own.
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
DESCRIBE_TIMEOUT_MS = 240_000


def _browser_missing() -> str | None:
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the python package playwright is not installed (pip install -e '.[test]')"
    if not Path(CHROMIUM).exists():
        return f"no Chromium at {CHROMIUM} (apt-get install chromium)"
    return None


@pytest.fixture(scope="module")
def base_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    missing = _browser_missing()
    if missing is not None:
        if os.environ.get("CI") == "true":
            pytest.fail(f"browser tests need a browser, and CI=true: {missing}")
        pytest.skip(f"browser tests skipped: {missing}")
    with live_server(tmp_path_factory.mktemp("browser")) as url:
        yield url


class Offline:
    """A browser page whose requests to anything but 127.0.0.1 are aborted and recorded."""

    def __init__(self, page: Any) -> None:
        self.page = page
        self.blocked: list[str] = []
        self.errors: list[str] = []
        page.route("**/*", self._route)
        page.on("pageerror", lambda error: self.errors.append(str(error)))

    def _route(self, route: Any) -> None:
        url = route.request.url
        host = urlsplit(url).hostname
        if url.startswith("data:") or host == "127.0.0.1":
            route.continue_()
        else:
            self.blocked.append(url)
            route.abort()


@pytest.fixture(scope="module")
def browser(base_url: str) -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    ARTIFACTS.mkdir(exist_ok=True)
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS
        )
        yield browser
        browser.close()


@pytest.fixture
def offline(browser: Any) -> Iterator[Offline]:
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    page.set_default_timeout(30_000)
    yield Offline(page)
    context.close()


CANVAS_PIXELS = """(selector) => {
  const source = document.querySelector(selector);
  const copy = document.createElement("canvas");
  copy.width = source.width; copy.height = source.height;
  const context = copy.getContext("2d");
  context.drawImage(source, 0, 0);
  const data = context.getImageData(0, 0, copy.width, copy.height).data;
  let painted = 0; const colours = new Set();
  for (let i = 0; i < data.length; i += 4) {
    if (data[i] < 245 || data[i + 1] < 245 || data[i + 2] < 245) {
      painted++; colours.add((data[i] >> 3) << 10 | (data[i + 1] >> 3) << 5 | data[i + 2] >> 3);
    }
  }
  return {painted, colours: colours.size, total: data.length / 4, url: copy.toDataURL()};
}"""


def canvas_pixels(page: Any, selector: str) -> dict[str, Any]:
    return page.evaluate(CANVAS_PIXELS, selector)


def test_viewer_upload_model_page_similar_search_and_database(
    offline: Offline, base_url: str
) -> None:
    page = offline.page
    page.goto(f"{base_url}/")
    parts = [str(PARTS / "angle_block.STL"), str(PARTS / "cylinder.stl")]
    page.set_input_files("#file-input", parts)
    for name in ("angle_block.STL", "cylinder.stl"):
        page.locator(f'li[data-file="{name}"] .outcome', has_text="accepted").wait_for()
    ready = page.locator('#models [data-status="ready"]')
    page.wait_for_function(
        "() => document.querySelectorAll('#models [data-status=\"ready\"]').length === 2",
        timeout=DESCRIBE_TIMEOUT_MS,
    )
    assert ready.count() == 2
    page.fill("#text-filter", "cylinder")
    assert page.locator("#models tr").count() == 1
    page.fill("#text-filter", "")
    page.screenshot(path=ARTIFACTS / "catalogue.png", full_page=True)

    page.click("#models a:text('angle_block.STL')")
    page.wait_for_selector("canvas.view[data-rendered]")
    first = canvas_pixels(page, "canvas.view")
    assert first["painted"] > 2000, first["painted"]
    assert first["colours"] > 20, "the HKS colouring must vary over the part"
    card = page.locator("#similar .card")
    card.first.wait_for()
    assert card.count() == 1
    assert "cylinder.stl" in card.first.inner_text()
    score = float(card.first.locator(".score").inner_text().removeprefix("score "))
    assert 0 < score <= 1
    assert page.locator("#facts [data-fact='cutoff n']").inner_text().isdigit()
    # Its size (issue 21): L x W x H in the file's units.
    assert page.locator("#facts [data-fact='size (L x W x H)']").inner_text().count(" x ") == 2

    page.fill("#time-slider", "0")
    page.dispatch_event("#time-slider", "input")
    page.wait_for_timeout(300)
    assert canvas_pixels(page, "canvas.view")["url"] != first["url"], "the slider recolours"
    card.first.locator("button", has_text="side by side").click()
    page.wait_for_function(
        "() => document.querySelectorAll('canvas.view[data-rendered]').length === 2"
    )
    assert canvas_pixels(page, ".viewbox:nth-child(2) canvas.view")["painted"] > 2000
    page.screenshot(path=ARTIFACTS / "model-page.png", full_page=True)

    # Load time of a model page, measured (not asserted): navigation to the first 3D frame.
    model_url = page.url
    timings = []
    for _ in range(3):
        page.goto("about:blank")
        page.goto(model_url)
        page.wait_for_selector("canvas.view[data-rendered]")
        rendered = "() => +document.querySelector('canvas.view').dataset.rendered"
        timings.append(page.evaluate(rendered))
    (ARTIFACTS / "model-page-load.json").write_text(json.dumps({"ms": timings}))

    page.goto(f"{base_url}/#/search")
    page.set_input_files("#search-input", str(SCAN))
    results = page.locator("#search-results .card")
    results.nth(1).wait_for(timeout=DESCRIBE_TIMEOUT_MS)
    assert "angle_block.STL" in results.first.inner_text()
    page.screenshot(path=ARTIFACTS / "search.png", full_page=True)

    page.goto(f"{base_url}/#/database")
    page.locator("#cutoff-summary", has_text="2 ready models").wait_for()
    page.wait_for_timeout(200)
    assert canvas_pixels(page, "#cutoff-plot")["painted"] > 200
    page.screenshot(path=ARTIFACTS / "database.png", full_page=True)

    assert offline.blocked == [], offline.blocked
    assert offline.errors == [], offline.errors


@pytest.mark.parametrize(
    ("path", "rendered"),
    [("/docs", ".swagger-ui .opblock-summary-path"), ("/redoc", "h1:text('shapesearch')")],
)
def test_api_docs_render_offline(
    offline: Offline, base_url: str, path: str, rendered: str
) -> None:
    page = offline.page
    page.goto(f"{base_url}{path}")
    page.wait_for_selector(rendered)
    assert page.locator(rendered).count() >= 1
    if path == "/docs":
        assert page.locator(".opblock").count() >= 10  # every operation of the API
    page.screenshot(path=ARTIFACTS / f"{path.strip('/')}.png")
    assert offline.blocked == [], offline.blocked
    assert offline.errors == [], offline.errors


def test_with_api_keys_the_viewer_asks_for_a_key_and_sends_it_as_a_header(
    browser: Any, tmp_path: Path
) -> None:
    from sqlalchemy import create_engine
    from sqlalchemy.orm import sessionmaker

    from app.auth.keys import create_key

    with live_server(tmp_path) as url:
        engine = create_engine(f"sqlite:///{tmp_path / 'shapesearch.db'}")
        with sessionmaker(engine).begin() as session:
            keys = {tenant: create_key(session, tenant) for tenant in ("acme", "other")}
        engine.dispose()
        for tenant, part in (("acme", "cylinder.stl"), ("other", "round.stl")):
            response = httpx.post(
                f"{url}/v1/models",
                files={"file": (part, (PARTS / part).read_bytes())},
                data={"name": f"{tenant}-{part}"},
                headers={"Authorization": f"Bearer {keys[tenant]}"},
            )
            assert response.status_code == 202, response.text

        context = browser.new_context()
        page = context.new_page()
        offline = Offline(page)
        sent: list[tuple[str, str | None]] = []
        page.on("request", lambda r: sent.append((r.url, r.headers.get("authorization"))))
        page.goto(f"{url}/")
        page.wait_for_selector("#key-dialog[open]")
        page.fill("#key-input", keys["acme"])
        page.click("#key-form button")
        page.locator("#models tr").first.wait_for()
        page.wait_for_timeout(500)
        names = page.locator("#models tr td:first-child").all_inner_texts()
        context.close()

    assert names == ["acme-cylinder.stl"], "only the key's tenant's models are shown"
    api_calls = [(u, auth) for u, auth in sent if "/v1/" in u]
    assert api_calls and any(auth == f"Bearer {keys['acme']}" for _, auth in api_calls)
    assert all(keys["acme"] not in u for u, _ in sent), "the key never goes into a URL"
    assert offline.blocked == [] and offline.errors == []


def _stretched_copy(path: Path, share: float) -> bytes:
    """The mesh at ``path`` with the half beyond the middle of its longest extent stretched
    so that its end moves by ``share`` of the length."""
    import numpy as np
    import trimesh

    mesh = trimesh.load(path, file_type="stl")
    vertices = np.asarray(mesh.vertices).copy()
    axis = int(np.argmax(np.ptp(vertices, axis=0)))
    low, high = vertices[:, axis].min(), vertices[:, axis].max()
    middle = (low + high) / 2
    weight = np.clip((vertices[:, axis] - middle) / (high - middle), 0.0, None)
    vertices[:, axis] += weight * share * (high - low)
    mesh.vertices = vertices
    return bytes(mesh.export(file_type="stl"))


def _single_view_scan(path: Path) -> bytes:
    """One simulated view of the part at ``path`` (noise, stray points), turned and in
    metres, as an .xyz file."""
    import numpy as np

    from core.evaluation.scans import ScanSettings, random_rotation, single_view_scan
    from core.io import load_points

    rng = np.random.default_rng(8)
    view = single_view_scan(load_points(path, max_points=20000, seed=3).points, rng,
                            ScanSettings())
    scan = (view @ random_rotation(rng).T) / 1000.0
    return "\n".join(" ".join(f"{v:.7g}" for v in row) for row in scan).encode()


def test_compare_view_places_one_part_on_another_and_a_scan_on_its_part(
    browser: Any, tmp_path: Path
) -> None:
    """With the default engine (its scores are calibrated, so the cards say them in words):
    a part and a copy with one end stretched, compared from the part's similar card; then a
    single-view scan searched and placed on its part."""
    from app.settings import Settings

    defaults = {f"SHAPESEARCH_{name.upper()}": str(Settings.model_fields[name].default)
                for name in ("max_points", "upload_check_points", "cutoff_seed",
                             "cutoff_n_min", "cutoff_n_max")}
    part = PARTS / "featuretype.STL"
    files = {"featuretype.STL": part.read_bytes(),
             "featuretype-long.STL": _stretched_copy(part, 0.10),
             "angle_block.STL": (PARTS / "angle_block.STL").read_bytes()}
    with live_server(tmp_path, extra_env=defaults) as url:
        ids = {}
        for name, content in files.items():
            response = httpx.post(f"{url}/v1/models", files={"file": (name, content)},
                                  data={"name": name, "units": "mm"})
            assert response.status_code == 202, response.text
            ids[name] = response.json()["id"]
        for model_id in ids.values():
            for _ in range(DESCRIBE_TIMEOUT_MS // 500):
                if httpx.get(f"{url}/v1/models/{model_id}").json()["status"] == "ready":
                    break
                time.sleep(0.5)
            else:
                raise AssertionError(f"model {model_id} was not described in time")

        context = browser.new_context(viewport={"width": 1280, "height": 900})
        page = context.new_page()
        page.set_default_timeout(60_000)
        offline = Offline(page)
        page.goto(f"{url}/#/models/{ids['featuretype.STL']}")
        card = page.locator(f'#similar .card[data-model-id="{ids["featuretype-long.STL"]}"]')
        card.wait_for()
        # The score in words beside the raw one.
        assert card.locator(".likeness").inner_text() in ("copy", "same kind")
        assert page.locator("#similar .likeness").count() == 2
        card.locator("button", has_text="compare").click()

        page.wait_for_selector("#compare-canvas[data-rendered]")
        assert page.url.endswith(f"#/models/{ids['featuretype.STL']}/compare/"
                                 f"{ids['featuretype-long.STL']}")
        figures = page.locator("#compare-figures")
        for name in ("RMS", "mean", "95th percentile", "maximum"):  # each part's points
            cells = figures.locator(f'[data-figure="{name}"]').all_inner_texts()
            assert len(cells) == 2 and all(cell.endswith(" mm") for cell in cells), cells
        assert figures.locator('[data-figure="scale"]').inner_text() == "1"
        assert len(figures.locator('[data-figure="size ratios"]').inner_text().split(" x ")) == 3
        legend = page.locator("#compare-legend")
        assert legend.is_visible() and "mm" in legend.inner_text()
        assert "tolerance" in legend.inner_text()
        page.wait_for_timeout(300)
        both = canvas_pixels(page, "#compare-canvas")
        assert both["painted"] > 2000 and both["colours"] > 20, "coloured by deviation"
        page.screenshot(path=ARTIFACTS / "compare.png", full_page=True)
        page.click('#compare-toggle [data-show="model"]')
        page.wait_for_timeout(300)
        alone = canvas_pixels(page, "#compare-canvas")
        assert alone["url"] != both["url"] and alone["colours"] < both["colours"]
        assert page.get_attribute('#compare-toggle [data-show="model"]',
                                  "aria-pressed") == "true"

        scan = tmp_path / "featuretype-view.xyz"
        scan.write_bytes(_single_view_scan(part))
        page.goto(f"{url}/#/search")
        page.set_input_files("#search-input", str(scan))
        page.locator("#search-results .card").first.wait_for(timeout=DESCRIBE_TIMEOUT_MS)
        # The first answers are explained (whichever way they are ordered): the part's card
        # places the scan on it.
        found = page.locator(f'#search-results .card[data-model-id="{ids["featuretype.STL"]}"]')
        found.locator("button", has_text="compare").click()
        page.wait_for_selector("#search-compare #compare-canvas[data-rendered]")
        placed = page.locator("#search-compare #compare-figures")
        assert "%" in placed.locator('[data-figure^="part covered"]').inner_text()
        assert " mm" in placed.locator('[data-figure="scan RMS from the part"]').inner_text()
        assert page.locator("#search-compare #compare-legend").is_visible()
        page.wait_for_timeout(300)
        page.screenshot(path=ARTIFACTS / "search-compare.png", full_page=True)
        assert offline.blocked == [] and offline.errors == []
        context.close()
