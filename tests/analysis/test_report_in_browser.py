"""The three paper studies' demo reports, opened in a real browser (headless Chromium through
its WebDriver): every image decodes, the console stays clean, and a screenshot of the whole page
is saved under the test output, ``out/test-browser/STUDY.png``, for people to look at.

Chromium and chromium-driver are Debian packages that ``make system-deps`` installs
(``scripts/system-deps.sh``); without them this test fails and says so."""

import re
import shutil
from html import unescape
from pathlib import Path

import pytest

from glarelab.demo import run_demo

STUDIES = ["yoshida2008", "spencer1995", "luidolt2020"]
WIDTH_PX = 1200  # a laptop's browser window
MAX_HEIGHT_PX = 20000  # Chromium's limit for one screenshot is larger; the reports are ~9000


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    folder = tmp_path_factory.mktemp("demos")
    return {
        study: run_demo(study, folder / study, participants=10, seed=1, log=lambda _: None)
        for study in STUDIES
    }


@pytest.fixture(scope="module")
def screenshots():
    """``out/test-browser/`` of the checkout (ignored by git): pytest's own temporary folders
    are pruned after three runs, too soon for someone to look."""
    folder = Path(__file__).parents[2] / "out" / "test-browser"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="module")
def browser():
    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    if not (chromium and driver):
        pytest.fail(
            "headless Chromium and its WebDriver are needed to open the reports: run "
            "`make system-deps` (Debian packages chromium and chromium-driver)"
        )
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = chromium
    for argument in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        f"--window-size={WIDTH_PX},900",
    ):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    session = webdriver.Chrome(options=options, service=Service(driver))
    yield session
    session.quit()


@pytest.mark.parametrize("study", STUDIES)
def test_the_demo_report_shows_in_a_browser(demos, browser, study, screenshots):
    report = demos[study]
    browser.set_window_size(WIDTH_PX, 900)
    browser.get(report.resolve().as_uri())
    images = browser.execute_script(
        "return Array.from(document.images).map(i => "
        "({alt: i.alt, complete: i.complete, width: i.naturalWidth, height: i.naturalHeight}))"
    )
    html = report.read_text()
    assert len(images) == html.count("<img ") >= 2
    undecoded = [i["alt"] for i in images if not (i["complete"] and i["width"] and i["height"])]
    assert not undecoded, f"{study}: images that did not decode: {undecoded}"
    console = [entry for entry in browser.get_log("browser") if entry["level"] != "INFO"]
    assert not console, f"{study}: the console reported {console}"
    # the figures are numbered in page order, each with its caption
    numbers = [int(n) for n in re.findall(r"<b>Figure (\d+)\.</b>", html)]
    assert numbers == list(range(1, len(images) + 1))
    height = browser.execute_script("return document.documentElement.scrollHeight")
    browser.set_window_size(WIDTH_PX, min(height + 200, MAX_HEIGHT_PX))
    screenshot = screenshots / f"{study}.png"
    assert browser.save_screenshot(str(screenshot))
    assert screenshot.stat().st_size > 50_000
    print(f"{study}: {len(images)} figures; screenshot {screenshot}")


def test_the_yoshida_demo_report_shows_the_stimuli_among_five_figures(demos):
    html = demos["yoshida2008"].read_text()
    titles = [unescape(t) for t in re.findall(r"<b>Figure \d+\.</b> <i>([^<]*)\.</i>", html)]
    assert len(titles) >= 5
    assert "The references of Method I (Gaussian) as the display showed them" in titles
    assert "The glare-free targets at their start luminances" in titles
    assert "Every participant's matches" in titles
    assert Path(demos["yoshida2008"].parent / "stimulus_01.png").is_file()
