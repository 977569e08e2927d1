"""The HTML player in a real headless Chromium: a recorded run of the core, saved, loaded back and
written as one file, replays with no simulator and no network.

Set SIGNORINI_UPDATE_DOCS=1 to refresh the README's screenshot (docs/player.png) from this test.
"""

import io
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from playwright import sync_api as playwright

from signorini import output, scenes
from signorini.player import write_html
from signorini.trajectory import load_trajectory

from browser import launch

WIDTH, HEIGHT = 960, 600
DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def page_file(tmp_path_factory):
    """boxes for 0.5 s, saved and loaded: the page is written from the file alone."""
    folder = tmp_path_factory.mktemp("player")
    record = output.run(scenes.build("boxes"), steps=120, progress=False)
    loaded = load_trajectory(record.save(folder / "boxes.npz"))
    return write_html(folder / "boxes.html", loaded), loaded


@pytest.fixture(scope="module")
def browser():
    with playwright.sync_playwright() as p:
        b = launch(p)
        yield b
        b.close()


def open_page(browser, path):
    """A page showing the player, with every JavaScript error and failed request collected."""
    page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
    errors, requests = [], []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("request", lambda r: requests.append(r.url))
    page.goto(Path(path).resolve().as_uri())
    page.wait_for_function("window.signoriniPlayer && window.signoriniPlayer.rendered > 0")
    return page, errors, requests


def settle(page):
    page.wait_for_function("!window.signoriniPlayer.dirty")


def scrub(page, frame):
    """Drag the timeline as a person would: set the range input and fire its input event."""
    page.eval_on_selector("#timeline", "(el, f) => { el.value = String(f); el.dispatchEvent(new Event('input')); }", frame)
    settle(page)


def shot(page):
    return np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB"), dtype=np.int16)


def boxes_of(page, bodies):
    return [page.evaluate(f"window.signoriniPlayer.screenBox({i})") for i in bodies]


@pytest.mark.slow
def test_player_replays_offline_and_only_moving_bodies_change_pixels(browser, page_file):
    path, record = page_file
    page, errors, requests = open_page(browser, path)
    assert page.evaluate("window.signoriniPlayer.frames") == record.frames
    # the file needs nothing from outside: the only request is the page itself
    assert all(url.startswith("file:") for url in requests), requests

    scrub(page, 0)
    first = shot(page)
    scrub(page, 0)
    assert np.array_equal(first, shot(page)), "the same frame drew different pixels"
    before = boxes_of(page, range(record.num_bodies))

    last = record.frames - 1
    scrub(page, last)
    assert page.evaluate("window.signoriniPlayer.frame") == last
    after = boxes_of(page, range(record.num_bodies))
    second = shot(page)
    assert "t = %.3f s" % record.time[last] in page.inner_text("#clock")

    # where the bodies were or are now (plus a margin for contact markers and arrows) pixels change;
    # the 3-D view elsewhere, and the ground, stay exactly as they were
    changed = np.any(first != second, axis=2)
    canvas = np.zeros_like(changed)
    canvas[40:HEIGHT - 44, :] = True            # below the title and info text, above the control bar
    moving = np.zeros_like(changed)
    for i in record.dynamic:
        for box in (before[i], after[i]):
            x0, x1 = int(max(box["left"] - 30, 0)), int(min(box["right"] + 30, WIDTH))
            y0, y1 = int(max(box["top"] - 30, 0)), int(min(box["bottom"] + 30, HEIGHT))
            moving[y0:y1, x0:x1] = True
    # arrows of contact forces may reach further: the force layer is switched off for this check
    page.uncheck("#show-forces")
    settle(page)
    second = shot(page)
    scrub(page, 0)
    first = shot(page)
    page.check("#show-forces")
    changed = np.any(first != second, axis=2)
    outside = changed & canvas & ~moving
    assert outside.sum() == 0, f"{outside.sum()} pixels changed where nothing moved"
    for i in record.dynamic:
        # every dynamic body that moved on screen changed pixels where it was
        b, a = before[i], after[i]
        if abs(b["left"] - a["left"]) + abs(b["top"] - a["top"]) > 3:
            y0, y1 = int(max(b["top"], 0)), int(min(b["bottom"], HEIGHT))
            x0, x1 = int(max(b["left"], 0)), int(min(b["right"], WIDTH))
            assert changed[y0:y1, x0:x1].sum() > 20, record.names[i]
    assert (changed & canvas).sum() > 500
    assert errors == []


@pytest.mark.slow
def test_player_controls_toggle_layers_and_play(browser, page_file):
    path, record = page_file
    page, errors, _ = open_page(browser, path)
    last = record.frames - 1
    assert record.frame_contacts(last)["point"].shape[0] > 0
    scrub(page, last)

    # contact points, normals and forces each draw something in the 3-D view when switched on
    # (the view only: the ticked box itself and its focus ring change the control bar)
    def view():
        return shot(page)[40:HEIGHT - 44]

    page.uncheck("#show-contacts")
    page.uncheck("#show-forces")
    settle(page)
    bare = view()
    for toggle in ("#show-contacts", "#show-normals", "#show-forces"):
        page.check(toggle)
        settle(page)
        assert np.any(view() != bare), toggle
        page.uncheck(toggle)
        settle(page)
        assert np.array_equal(view(), bare), toggle

    # the play button runs the clock from the start; pause stops it (at a quarter speed the 0.5 s
    # recording plays for 2 s, so a loaded machine still clicks pause before it reaches the end
    # and stops by itself, when the click would start it again)
    page.keyboard.press("Home")
    page.select_option("#speed", "0.25")
    settle(page)
    page.click("#play")
    page.wait_for_function("window.signoriniPlayer.frame > 10")
    page.click("#play")
    stopped = page.evaluate("window.signoriniPlayer.frame")
    page.wait_for_timeout(200)
    assert page.evaluate("window.signoriniPlayer.frame") == stopped
    # arrow keys step one frame
    page.keyboard.press("ArrowRight")
    assert page.evaluate("window.signoriniPlayer.frame") == min(stopped + 1, last)

    # a drag orbits the camera: the view changes
    settle(page)
    before = shot(page)
    page.mouse.move(WIDTH / 2, HEIGHT / 2)
    page.mouse.down()
    page.mouse.move(WIDTH / 2 + 120, HEIGHT / 2 + 30, steps=5)
    page.mouse.up()
    settle(page)
    assert np.any(shot(page) != before)
    assert errors == []


def test_player_screenshot_for_the_readme(browser, tmp_path):
    """The shapes scene settled, with contact points, normals and forces; written to docs/ on request."""
    record = output.run(scenes.build("shapes"), steps=360, progress=False, stride=2)
    path = write_html(tmp_path / "shapes.html", record)
    page, errors, _ = open_page(browser, path)
    scrub(page, record.frame_at(1.2))
    page.check("#show-normals")
    settle(page)
    picture = tmp_path / "player.png"
    page.screenshot(path=str(picture))
    assert errors == []
    assert np.asarray(Image.open(picture)).std() > 5  # not a blank page
    if os.environ.get("SIGNORINI_UPDATE_DOCS"):
        DOCS.mkdir(exist_ok=True)
        shutil.copy(picture, DOCS / "player.png")
