"""The HTML report in a real headless Chromium: every image loads, no script fails, it draws.

The page of a disagreeing comparison (the Cornell box at 64 spp, rendered 5 % too bright)
is loaded from ``file://`` twice: ``--dump-dom`` prints the DOM after the load event, where
the page's own script has written ``data-images-loaded="N/M"`` and ``data-errors`` on
``<body>``; ``--screenshot`` must give a picture that is not blank. Skips, saying why,
where no Chromium is on PATH (``.ci/run`` installs Debian's ``chromium`` when it can).
"""
from __future__ import annotations

import itertools
import os
import shutil
import signal
import subprocess
from html.parser import HTMLParser

import numpy as np
import pytest
from PIL import Image

from mitsuba_refs.report.html import write_html
from mitsuba_refs.report.results import write_json
from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.scenes import render_ours

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
#: Seconds a browser run may take before it is killed (a cold start takes a few).
TIMEOUT = 120
WINDOW = (1280, 2000)


def find_browser() -> str | None:
    """The first of :data:`BROWSERS` on PATH."""
    return next((found for found in map(shutil.which, BROWSERS) if found), None)


BROWSER = find_browser()
pytestmark = pytest.mark.skipif(
    BROWSER is None, reason=f"no headless browser on PATH (looked for {', '.join(BROWSERS)}; "
                            "Debian: apt-get install chromium)")
_runs = itertools.count()


def run_browser(tmp_path, *arguments) -> subprocess.CompletedProcess:
    """Run the browser headless with a fresh profile; kill its whole process group on timeout."""
    profile = tmp_path / f"profile-{next(_runs)}"
    command = [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               "--no-first-run", "--disable-extensions", f"--user-data-dir={profile}", *arguments]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        out, err = process.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"{BROWSER} did not finish within {TIMEOUT} s: {' '.join(command)}")
    return subprocess.CompletedProcess(command, process.returncode, out, err)


def render_too_bright(*args, **kwargs):
    mean, variance = render_ours(*args, **kwargs)
    return mean * 1.05, variance * 1.05 ** 2


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    """index.html of a comparison that disagrees (so the z-map has tiles to outline)."""
    folder = tmp_path_factory.mktemp("browser")
    result = compare("cornell-box", "path", spp=64, convergence=True, ladder=(1, 4, 16), replicas=2,
                     processes=1, render=render_too_bright)
    records = write_json([result], folder / "results.json")
    return write_html(records, folder / "html")


class BodyAndImages(HTMLParser):
    """The attributes of ``<body>`` and how many ``<img>`` a document has."""

    def __init__(self):
        super().__init__()
        self.body, self.images = None, 0

    def handle_starttag(self, tag, attrs):
        if tag == "body":
            self.body = dict(attrs)
        elif tag == "img":
            self.images += 1


def parsed(text: str) -> BodyAndImages:
    parser = BodyAndImages()
    parser.feed(text)
    return parser


def test_every_image_loads_and_no_script_fails(page, tmp_path):
    in_file = parsed(page.read_text(encoding="utf-8")).images
    assert in_file == 6          # test, reference, z-map, relative difference, variance ratio, convergence
    done = run_browser(tmp_path, "--dump-dom", page.as_uri())
    assert done.returncode == 0, done.stderr[-2000:]
    dom = parsed(done.stdout)
    assert dom.body is not None, done.stdout[:2000]
    assert dom.images == in_file
    assert dom.body.get("data-images-loaded") == f"{in_file}/{in_file}", dom.body
    assert dom.body.get("data-errors") == "", dom.body


def test_screenshot_is_not_blank(page, tmp_path):
    shot = tmp_path / "report.png"
    done = run_browser(tmp_path, f"--screenshot={shot}", f"--window-size={WINDOW[0]},{WINDOW[1]}",
                       page.as_uri())
    assert done.returncode == 0 and shot.is_file(), done.stderr[-2000:]
    pixels = np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)
    assert pixels.shape == (WINDOW[1], WINDOW[0], 3)
    assert pixels.var() > 0
