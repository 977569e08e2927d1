"""The HTML player in a real headless Chromium: a recorded run of the core, saved, loaded back and
written as one file, replays with no simulator and no network. Its contact events (issue 24): a
bouncing ball's beginnings ticked on the timeline at the analytic bounce steps, marked at the
contact point, hidden by their toggle, reached by the next / previous event keys; the events the
page embeds checked against the record's (no browser needed); a file without events plays as before.

Set SIGNORINI_UPDATE_DOCS=1 to refresh the README's screenshot (docs/player.png) from this test.
"""

import base64
import dataclasses
import io
import json
import math
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from playwright import sync_api as playwright

import signorini as sg
from signorini import output, scenes
from signorini.player import EVENT_COLOURS, EVENT_FADE, EVENT_LABELS, write_html
from signorini.trajectory import EVENT_KINDS, load_trajectory

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


# contact events (issue 24): a ball dropped from DROP (its lowest point) onto the ground, restitution E

G, DROP, E, RADIUS, DT = 9.81, 1.0, 0.8, 0.1, 1 / 240


def ball_record(steps, stride):
    w = sg.World(gravity=(0, 0, -G), sleeping=False)
    w.add_static(sg.Plane((0, 0, 1), 0.0))
    w.add_body(sg.Sphere(RADIUS), mass=1.0, position=(0, 0, RADIUS + DROP), restitution=E)
    rec = sg.Recorder(w, stride=stride, names=["ground", "ball"])
    rec.step(DT, steps)
    return rec.record()


def bounce_times(until):
    """The impacts before `until` s: the drop takes v0 / g, v0 = sqrt(2 g h), and bounce i leaves at
    e^i v0 and lands 2 e^i v0 / g later."""
    v0 = math.sqrt(2 * G * DROP)
    times = [v0 / G]
    while times[-1] + 2 * v0 * E ** len(times) / G < until:
        times.append(times[-1] + 2 * v0 * E ** len(times) / G)
    return times


def page_data(path) -> dict:
    """The JSON object a written page hands its script."""
    text = Path(path).read_text(encoding="utf-8")
    found = re.search(r'<script id="signorini-data" type="application/json">(.*?)</script>', text, re.S)
    return json.loads(found.group(1))


def decode(b64, dtype):
    return np.frombuffer(base64.b64decode(b64), dtype=dtype)


def test_the_page_embeds_the_records_events_with_the_frame_that_shows_each(tmp_path):
    # stride 3: the event of step k (0-based) shows from frame ceil((k + 1) / 3), the first taken after it
    r = ball_record(480, 3)
    page = write_html(tmp_path / "ball.html", r)
    assert write_html(tmp_path / "again.html", r).read_bytes() == page.read_bytes()  # the same bytes every time
    ev = page_data(page)["events"]
    assert ev["kinds"] == list(EVENT_LABELS) and ev["colours"] == ["#%02x%02x%02x" % c for c in EVENT_COLOURS]
    kind, step, frame = decode(ev["kind"], "u1"), decode(ev["step"], "<u4").astype(np.int64), decode(ev["frame"], "<u4")
    assert len(kind) == sum(len(r.events[k]["step"]) for k in EVENT_KINDS)
    assert np.all(np.diff(step) >= 0)  # by step
    np.testing.assert_array_equal(frame, -(-(step + 1) // 3))
    # each kind's rows are the record's, in its order (float32 for the numbers)
    for i, k in enumerate(EVENT_KINDS):
        rows, e = kind == i, r.events[k]
        for name, field, dtype in (("step", "step", "<u4"), ("a", "body_a", "<u4"), ("b", "body_b", "<u4"),
                                   ("point", "point", "<f4"), ("normal", "normal", "<f4"), ("speed", "speed", "<f4"),
                                   ("impulse", "impulse", "<f4")):
            width = 3 if field in ("point", "normal") else 1
            got = decode(ev[name], dtype).reshape(len(kind), width)[rows]
            np.testing.assert_array_equal(got, e[field].astype(dtype).reshape(-1, width), err_msg=f"{k}.{field}")
    # a begin per bounce of the run
    assert np.count_nonzero(kind == 0) == len(bounce_times(480 * DT)) == 3

    # a page thinned to fit its budget shows each event from the first frame it kept after the event
    thin = page_data(write_html(tmp_path / "thin.html", r, max_frame_bytes=3_000))
    time = decode(thin["time"], "<f4")
    assert thin["frames"] < r.frames
    ev = thin["events"]
    step, frame = decode(ev["step"], "<u4"), decode(ev["frame"], "<u4").astype(np.int64)
    happened = r.step_time[step].astype(np.float32)
    assert np.all(time[frame] >= happened) and np.all((frame == 0) | (time[np.maximum(frame - 1, 0)] < happened))

    # a record without events (a file written before them) gives the same page with none
    none = dataclasses.replace(r, events={k: {f: v[:0] for f, v in fields.items()} for k, fields in r.events.items()})
    with_events, without = page_data(page), page_data(write_html(tmp_path / "none.html", none))
    assert with_events.pop("events") is not None and without.pop("events") is None
    assert with_events == without


def without_events(path, folder):
    """The trajectory file as written before events were recorded (no event_* arrays), loaded."""
    with np.load(path) as z:
        data = {k: z[k] for k in z.files if not k.startswith("event_")}
    older = folder / "older.npz"
    np.savez_compressed(older, **data)
    return load_trajectory(older)


@pytest.fixture(scope="module")
def ball_pages(tmp_path_factory):
    """The ball for 2.4 s (four bounces), every step a frame, saved and loaded; and the same file
    without its events."""
    folder = tmp_path_factory.mktemp("ball")
    saved = ball_record(576, 1).save(folder / "ball.npz")
    record, older = load_trajectory(saved), without_events(saved, folder)
    assert sum(len(older.events[k]["step"]) for k in EVENT_KINDS) == 0
    return write_html(folder / "ball.html", record), write_html(folder / "older.html", older), record


PLAYER = "window.signoriniPlayer"


def frame_of(page):
    return page.evaluate(f"{PLAYER}.frame")


@pytest.mark.slow
def test_the_timeline_ticks_each_bounce_at_its_analytic_step_where_the_slider_shows_it(browser, ball_pages):
    path, _, record = ball_pages
    page, errors, _ = open_page(browser, path)
    ticks = page.evaluate(f"{PLAYER}.ticks()")
    begins = [t for t in ticks if t["kind"] == "begin"]
    times = bounce_times(record.steps * DT)
    assert len(begins) == len(times) == 4
    # frame n shows the state after n steps: bounce i at t_i first shows in frame ceil(t_i / dt). The
    # contact is found at the start of the step that would carry the ball through the ground (up to
    # a step early), and each rebound carries the bounces' errors before it on (the restitution
    # acts on the approach with the step's gravity in, a flight of symplectic Euler lands about a
    # step early), so bounce i is within i + 1 steps
    for i, (tick, t) in enumerate(zip(begins, times)):
        assert abs(tick["frame"] - math.ceil(t / DT)) <= i + 1, (i, tick["frame"], t / DT)
    # each bounce is a hit (faster than 1 m/s) and ends in the step after it, having reversed
    assert [t["frame"] for t in ticks if t["kind"] == "hit"] == [t["frame"] for t in begins]
    assert [t["frame"] for t in ticks if t["kind"] == "end"] == [t["frame"] + 1 for t in begins]

    # each tick is drawn in its kind's colour
    picture = shot(page)
    for tick in ticks:
        x, y = int(tick["x"]), int(tick["y"])
        colour = EVENT_COLOURS[EVENT_LABELS.index(tick["kind"])]
        assert np.any(np.all(np.abs(picture[y, x - 2:x + 3] - colour) <= 8, axis=1)), tick

    # a click on the slider at a tick goes to the tick's frame, to the slider's resolution (frames a
    # pixel of its track, 16 px shorter than the slider, the thumb's width)
    for i in range(len(begins)):
        tick = [t for t in page.evaluate(f"{PLAYER}.ticks()") if t["kind"] == "begin"][i]
        left, top, width, height = page.eval_on_selector(
            "#timeline", "el => { const r = el.getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; }")
        per_pixel = (record.frames - 1) / (width - 16)
        page.mouse.click(tick["x"], top + height / 2)
        settle(page)
        assert abs(frame_of(page) - tick["frame"]) <= 1.5 * per_pixel + 1, (tick, frame_of(page), per_pixel)
    assert errors == []


@pytest.mark.slow
def test_a_begin_is_marked_at_its_contact_point_fades_and_the_toggle_hides_it(browser, ball_pages):
    path, older_path, record = ball_pages
    page, errors, _ = open_page(browser, path)
    first = int(record.events["begin"]["step"][0]) + 1  # the frame after the first impact's step
    scrub(page, first)
    marks = page.evaluate(f"{PLAYER}.markers()")
    assert sorted(m["kind"] for m in marks) == ["begin", "hit"]
    v0 = math.sqrt(2 * G * DROP)
    ball = record.positions[first, 1]
    for m in marks:
        assert (m["a"], m["b"], m["frame"], m["alpha"]) == (0, 1, first, 1)
        # on the ground under the ball: the contact is found at most one step's fall, (v0 + g dt) dt,
        # before the ball meets the ground
        np.testing.assert_allclose(m["point"][:2], ball[:2], atol=1e-6)
        assert abs(m["point"][2]) <= (v0 + G * DT) * DT
    # the list names the kind, the bodies and the hit's speed: the approach at the start of the
    # impact step, below v0 by at most g dt
    speed = record.events["hits"]["speed"][0]
    assert v0 - G * DT <= speed <= v0
    lines = page.inner_text("#event-list").splitlines()
    assert len(lines) == 2 and "begin" in lines[0] and "ground / ball" in lines[0]
    assert "hit" in lines[1] and f"{speed:.2f} m/s" in lines[1]

    # the toggle hides the cross (pixels change near its point only) and the list; what is left is
    # exactly the page of the file without events
    def view():
        return shot(page)[:HEIGHT - 44]

    listed = page.eval_on_selector(
        "#event-list", "el => { const r = el.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; }")
    marked = view()
    page.uncheck("#show-events")
    settle(page)
    assert page.evaluate(f"{PLAYER}.markers()") == [] and page.inner_text("#event-list") == ""
    bare = view()
    changed = np.any(marked != bare, axis=2)
    changed[int(listed[1]):int(math.ceil(listed[3])) + 1, int(listed[0]):int(math.ceil(listed[2])) + 1] = False
    rows, cols = np.nonzero(changed)
    # the hit's normal is 0.06 of the camera's distance long, 0.08 of the view's height at 40 degrees
    assert len(rows) > 20
    assert np.hypot(cols - marks[0]["x"], rows - marks[0]["y"]).max() <= 0.15 * (HEIGHT - 44)
    older, older_errors, _ = open_page(browser, older_path)
    scrub(older, first)
    assert np.array_equal(shot(older)[:HEIGHT - 44], bare)

    # after its frame the cross fades over EVENT_FADE s of the run, then is gone
    page.check("#show-events")
    later = first + 30
    scrub(page, later)
    fading = [m for m in page.evaluate(f"{PLAYER}.markers()") if m["kind"] == "begin"]
    assert len(fading) == 1
    assert fading[0]["alpha"] == pytest.approx(1 - (record.time[later] - record.time[first]) / EVENT_FADE, abs=1e-6)
    scrub(page, first + math.ceil(EVENT_FADE / DT) + 1)  # a frame past the window (its end is float32 times apart)
    assert [m for m in page.evaluate(f"{PLAYER}.markers()") if m["kind"] == "begin"] == []
    assert errors == [] and older_errors == []


@pytest.mark.slow
def test_the_event_keys_go_to_the_next_and_the_previous_frame_with_events(browser, ball_pages):
    path, _, record = ball_pages
    page, errors, _ = open_page(browser, path)
    # every step a frame: the events of step k show from frame k + 1
    frames = sorted({int(k) + 1 for kind in EVENT_KINDS for k in record.events[kind]["step"]})
    assert len(frames) == 8  # four bounces: a begin (and hit), an end
    page.keyboard.press("Home")
    ahead = []
    for _ in frames:
        page.keyboard.press("]")
        ahead.append(frame_of(page))
    assert ahead == frames
    page.keyboard.press("]")  # none after the last: it stays
    assert frame_of(page) == frames[-1]
    back = []
    for _ in frames[1:]:
        page.keyboard.press("[")
        back.append(frame_of(page))
    assert back == frames[-2::-1]
    page.keyboard.press("[")
    assert frame_of(page) == frames[0]
    page.keyboard.press("PageDown")
    assert frame_of(page) == frames[1]
    page.keyboard.press("PageUp")
    assert frame_of(page) == frames[0]
    assert errors == []


@pytest.mark.slow
def test_a_file_without_events_plays_as_before(browser, ball_pages):
    _, older_path, record = ball_pages
    page, errors, _ = open_page(browser, older_path)
    assert page.evaluate(f"{PLAYER}.events") == 0 and page.evaluate(f"{PLAYER}.ticks()") == []
    assert page.is_hidden("#ticks") and page.is_hidden("#show-events")
    scrub(page, 100)
    for key in ("]", "[", "PageDown", "PageUp"):
        page.keyboard.press(key)
        assert frame_of(page) == 100, key
    page.keyboard.press("ArrowRight")
    assert frame_of(page) == 101
    assert page.evaluate(f"{PLAYER}.markers()") == [] and page.inner_text("#event-list") == ""
    page.click("#play")
    page.wait_for_function(f"{PLAYER}.frame > 110")
    page.evaluate(f"{PLAYER}.pause()")
    assert errors == []
