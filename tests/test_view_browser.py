"""``vidtrack view`` in a real headless Chromium: the page as a user meets it.

The real command serves the page on 127.0.0.1 (a child process); Selenium drives Debian's
``chromium`` through ``chromedriver``: it fits the run, clicks the frame to set the
origin (the zoom following the pointer), steps frames, places a point by hand, excludes a
frame, sets the target and removes it, and types a bad fps. In a run with throws/ it
picks a throw, places a point by clicking the zoom and excludes a frame.
Truth: tracks.csv written by the fit, the pixels the test clicked (worked out from the
element's size and the display scale the page states), scene.toml and the manual points
file read back by the scene loader and ``csv``. A screenshot of the page is kept
(``tmp_path/view.png``). Skipped, with the reason, where Selenium, chromium or
chromedriver are absent.
"""

import csv
import hashlib
import re
from pathlib import Path

import pandas as pd
import pytest

pytest.importorskip("flask", reason="vidtrack view needs Flask (pip install 'vidtrack[view]')")
webdriver = pytest.importorskip("selenium.webdriver",
                                reason="selenium is not installed (pip install selenium)")

from selenium.common.exceptions import WebDriverException  # noqa: E402
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402
from selenium.webdriver.support.ui import Select  # noqa: E402
from test_view import copy_run, copy_throws_run, serve, stop  # noqa: E402

from vidtrack.view.zoom import ZOOM_FACTOR, ZOOM_HALF_PX  # noqa: E402

#: Debian's packages chromium and chromium-driver install these.
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
#: Chromium's switches: headless, no sandbox (containers, root), nothing fetched.
SWITCHES = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
            "--disable-background-networking", "--disable-component-update",
            "--disable-sync", "--no-first-run", "--window-size=1400,1000")
#: How long a wait for the page may last before the test fails (s): not a speed check.
WAIT_S = 60


def _browser_missing():
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not Path(path).is_file():
            return f"no {path} (Debian: apt-get install {package})"
    return None


pytestmark = pytest.mark.skipif(_browser_missing() is not None,
                                reason=str(_browser_missing()))


@pytest.fixture
def browser(tmp_path):
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for s in SWITCHES:
        options.add_argument(s)
    options.add_argument(f"--user-data-dir={tmp_path / 'chromium-profile'}")
    try:
        driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    except WebDriverException as exc:
        pytest.skip(f"chromium did not start: {exc.msg}")
    yield driver
    driver.quit()


@pytest.fixture(params=[copy_run])
def page(request, tmp_path, browser):
    run = request.param(tmp_path / "run")
    proc, url = serve(run)
    browser.get(url)
    wait = WebDriverWait(browser, WAIT_S)
    wait.until(lambda d: d.find_element(By.TAG_NAME, "body").get_attribute("data-ready"))
    yield run, browser, wait
    code, err = stop(proc)
    assert code == 0, err


def click_frame(browser, frame_px, *, click=True):
    """Click the drawn frame where the footage's pixel ``frame_px`` is (or only point at
    it); returns the pixel the click lands on and how far off it may be in frame pixels:
    one CSS pixel (the click's offsets are whole CSS pixels from the element's centre,
    which may not be)."""
    img = browser.find_element(By.ID, "frame")
    scale = browser.execute_script("return state.views[view].scale;")
    w, h = img.size["width"], img.size["height"]
    nat_w = browser.execute_script("return arguments[0].naturalWidth;", img)
    css_per_px = w / nat_w
    dx = round(((frame_px[0] + 0.5) * scale - 0.5) * css_per_px - w / 2)
    dy = round(((frame_px[1] + 0.5) * scale - 0.5) * css_per_px - h / 2)
    move = ActionChains(browser).move_to_element_with_offset(img, dx, dy)
    (move.click() if click else move).perform()
    return ([((w / 2 + dx) / css_per_px + 0.5) / scale - 0.5,
             ((h / 2 + dy) / css_per_px + 0.5) / scale - 0.5], 1.0 / (css_per_px * scale))


def message(browser, wait, text):
    wait.until(lambda d: text in d.find_element(By.ID, "message").text)
    return browser.find_element(By.ID, "message")


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def test_set_up_and_correct_a_run_by_clicking(page, tmp_path):
    from vidtrack.scene import load_scene

    run, browser, wait = page
    # fitted from the page: the tracker's point of the frame shown, as tracks.csv has it
    browser.find_element(By.ID, "fit").click()
    wait.until(lambda d: d.find_element(By.ID, "fit-status").text.startswith(("done", "failed")))
    assert browser.find_element(By.ID, "fit-status").text.startswith("done")
    table = pd.read_csv(run / "vidtrack" / "tracks.csv")
    row = table[(table["view"] == "front") & (table["frame"] == 0)].iloc[0]
    wait.until(lambda d: "measured: -" not in d.find_element(By.ID, "info").text)
    shown = re.search(r"measured: ([-\d.]+), ([-\d.]+)",
                      browser.find_element(By.ID, "info").text)
    assert [float(shown[1]), float(shown[2])] == pytest.approx([row["u_px"], row["v_px"]],
                                                               abs=0.006)
    # the origin, clicked on the first frame
    browser.find_element(By.ID, "tool-origin").click()
    clicked, tol = click_frame(browser, (150.0, 90.0))
    message(browser, wait, "wrote scene.toml")
    origin = load_scene(run).views["front"].origin_px
    assert origin == pytest.approx(clicked, abs=tol)
    assert origin == pytest.approx((150.0, 90.0), abs=2 * tol)
    # the zoom follows the pointer: the footage's pixels around the pixel pointed at
    def zoomed_at(d):
        at = re.search(r"around ([-\d.]+), ([-\d.]+)", d.find_element(By.ID, "zoom-at").text)
        return at is not None and [float(at[1]), float(at[2])] == pytest.approx(clicked,
                                                                                 abs=tol)

    wait.until(zoomed_at)
    zoom = browser.find_element(By.ID, "zoom")
    wait.until(lambda d: zoom.is_displayed() and d.execute_script(
        "return arguments[0].complete && arguments[0].naturalWidth;", zoom))
    assert browser.execute_script("return arguments[0].naturalWidth;", zoom) == (
        (2 * ZOOM_HALF_PX + 1) * ZOOM_FACTOR)
    # two frames on, a point placed by hand
    browser.find_element(By.ID, "next").click()
    browser.find_element(By.ID, "next").click()
    wait.until(lambda d: d.find_element(By.ID, "info").text.startswith("frame 2 "))
    browser.find_element(By.ID, "tool-point").click()
    clicked, tol = click_frame(browser, (210.0, 60.0))
    message(browser, wait, "wrote front_manual.csv, scene.toml")
    with open(run / "front_manual.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["frame"]) for r in rows] == [2]
    assert [float(rows[0]["u_px"]), float(rows[0]["v_px"])] == pytest.approx(clicked, abs=tol)
    wait.until(lambda d: "placed by hand: -" not in d.find_element(By.ID, "info").text)
    # the next frame excluded
    browser.find_element(By.ID, "next").click()
    wait.until(lambda d: d.find_element(By.ID, "info").text.startswith("frame 3 "))
    browser.find_element(By.ID, "exclude").click()
    wait.until(lambda d: "excluded: yes" in d.find_element(By.ID, "info").text)
    assert load_scene(run).views["front"].exclude_frames == ((3, 4),)
    # the target clicked in this frame, then removed
    browser.find_element(By.ID, "tool-target").click()
    clicked, tol = click_frame(browser, (205.0, 55.0))
    wait.until(lambda d: "target: frame 3 at" in d.find_element(By.ID, "info").text)
    frame, at = load_scene(run).views["front"].target
    assert frame == 3 and at == pytest.approx(clicked, abs=tol)
    browser.find_element(By.ID, "remove-target").click()
    wait.until(lambda d: "target: -" in d.find_element(By.ID, "info").text)
    assert load_scene(run).views["front"].target is None
    # a bad fps: the loader's one line in the page, nothing written
    before = digest(run / "scene.toml")
    fps = browser.find_element(By.ID, "fps")
    fps.clear()
    fps.send_keys("0")
    browser.find_element(By.ID, "set-fps").click()
    shown = message(browser, wait, "views.front.fps must be > 0, got 0")
    assert shown.get_attribute("class") == "error" and "\n" not in shown.text
    assert digest(run / "scene.toml") == before
    shot = tmp_path / "view.png"
    assert browser.save_screenshot(str(shot))
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("page", [copy_throws_run], indirect=True)
def test_a_throw_picked_and_corrected_by_clicking_the_zoom(page, tmp_path):
    """Throw 02 picked; the zoom clicked three pixels right of and two above the pixel it
    is centred on places the point there, in throw 02's own file; an exclusion goes to
    throw 02's throw.toml; scene.toml is untouched."""
    run, browser, wait = page
    shared = digest(run / "scene.toml")
    Select(browser.find_element(By.ID, "throw")).select_by_value("02")
    wait.until(lambda d: d.find_element(By.TAG_NAME, "body").get_attribute("data-throw")
               == "02")
    assert browser.find_element(By.ID, "run").text.endswith("throw 02")
    click_frame(browser, (150.0, 60.0), click=False)          # the zoom follows the pointer
    zoom = browser.find_element(By.ID, "zoom")
    wait.until(lambda d: zoom.is_displayed() and d.execute_script(
        "return arguments[0].complete && arguments[0].naturalWidth;", zoom))
    wait.until(lambda d: "around 1" in d.find_element(By.ID, "zoom-at").text)
    at = re.search(r"around ([-\d.]+), ([-\d.]+)", browser.find_element(By.ID, "zoom-at").text)
    centre = [int(float(x) + 0.5) for x in (at[1], at[2])]   # the pixel outlined in the zoom
    assert centre == [150, 60]
    browser.find_element(By.ID, "tool-point").click()
    w = zoom.size["width"]
    css_per_px = w / browser.execute_script("return arguments[0].naturalWidth;", zoom)
    dx, dy = 3, -2                                  # frame pixels from the centre pixel
    ActionChains(browser).move_to_element_with_offset(
        zoom, round((ZOOM_HALF_PX + dx + 0.5) * ZOOM_FACTOR * css_per_px - w / 2),
        round((ZOOM_HALF_PX + dy + 0.5) * ZOOM_FACTOR * css_per_px - w / 2)).click().perform()
    message(browser, wait, "wrote throws/02/front_manual.csv, throws/02/throw.toml")
    with open(run / "throws" / "02" / "front_manual.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["frame"]) for r in rows] == [0]
    assert [float(rows[0]["u_px"]), float(rows[0]["v_px"])] == pytest.approx(
        [centre[0] + dx, centre[1] + dy], abs=1.0 / (ZOOM_FACTOR * css_per_px))
    browser.find_element(By.ID, "next").click()
    wait.until(lambda d: d.find_element(By.ID, "info").text.startswith("frame 1 "))
    browser.find_element(By.ID, "exclude").click()
    wait.until(lambda d: "excluded: yes" in d.find_element(By.ID, "info").text)
    from vidtrack.scene import load_scene, throw_scene

    scene = load_scene(run)
    assert throw_scene(scene, run / "throws" / "02").views["front"].exclude_frames == ((1, 2),)
    assert not (run / "throws" / "01" / "throw.toml").exists()
    assert digest(run / "scene.toml") == shared
    assert browser.save_screenshot(str(tmp_path / "view-throws.png"))
