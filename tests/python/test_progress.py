"""Progress bars that suit where stderr goes (signorini.progress): a tqdm bar on a terminal, a few
plain lines anywhere else (a CI log, a pipe), never a carriage return per refresh; and the run,
video and CoACD bars use them. The clock is a stand-in that moves a second per reading, so the
bars' one-second delay passes without waiting."""
import contextlib
import io
import itertools
from types import SimpleNamespace

import pytest

import signorini as sg
from signorini import output, progress


def make_scene(steps):
    """A ball dropped on the ground."""
    world = sg.World(gravity=(0, 0, -9.81))
    world.add_static(sg.Plane((0, 0, 1), 0.0))
    world.add_body(sg.Sphere(0.1), mass=1.0, position=(0, 0, 0.5))
    return SimpleNamespace(name="ball", world=world, dt=1 / 240, steps=steps, description="", snapshot_times=None)


class Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture
def fast_clock(monkeypatch):
    """time.monotonic as the progress module reads it: 0, 1, 2, ... seconds."""
    ticks = itertools.count()
    monkeypatch.setattr(progress.time, "monotonic", lambda: float(next(ticks)))


def test_off_a_terminal_a_bar_is_a_line_per_quarter_and_no_carriage_return(fast_clock):
    stream = io.StringIO()
    with progress.bar(2400, "pyramid", "step", file=stream, delay=1.0) as bar:
        assert isinstance(bar, progress.Lines)
        for _ in range(2400):
            bar.update(1)
    text = stream.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert [line.split(" [")[0] for line in lines] == [
        "pyramid: 600/2400 steps (25 %)", "pyramid: 1200/2400 steps (50 %)", "pyramid: 1800/2400 steps (75 %)",
        "pyramid: 2400/2400 steps (100 %)"]


def test_off_a_terminal_work_shorter_than_the_delay_prints_nothing():
    stream = io.StringIO()
    with progress.bar(100, "short", "step", file=stream, delay=3600.0) as bar:
        for _ in range(100):
            bar.update(1)
    assert stream.getvalue() == ""


def test_off_a_terminal_each_new_stage_is_a_line():
    # CoACD's bar: the total grows round by round, each round a stage named in the postfix
    stream = io.StringIO()
    bar = progress.bar(1, "CoACD", "pieces final", file=stream)
    for final, total, stage in ((0, 1, "round 1, cutting 1"), (0, 2, "round 2, cutting 2"), (3, 3, "merging"),
                                (3, 3, "3 after merging")):
        bar.total, bar.n = total, final
        bar.set_postfix_str(stage)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert [line.split(" [")[0] + line.split("]")[1] for line in lines] == [
        "CoACD: 0/1 pieces final (0 %), round 1, cutting 1", "CoACD: 0/2 pieces final (0 %), round 2, cutting 2",
        "CoACD: 3/3 pieces final (100 %), merging", "CoACD: 3/3 pieces final (100 %), 3 after merging"]


def test_on_a_terminal_a_bar_is_tqdm_redrawn_in_place():
    from tqdm import tqdm

    stream = Terminal()
    with progress.bar(10, "torus", "step", file=stream) as bar:
        assert isinstance(bar, tqdm)
        for _ in range(10):
            bar.update(1)
    assert "\r" in stream.getvalue() and "10/10" in stream.getvalue()


def test_a_run_logged_to_a_file_prints_a_few_plain_lines(fast_clock):
    # output.run's bar (the command line's `run`) with stderr not a terminal
    stream = io.StringIO()
    with contextlib.redirect_stderr(stream):
        output.run(make_scene(steps=200), progress=True)
    text = stream.getvalue()
    assert "\r" not in text
    assert [line.split(" [")[0] for line in text.splitlines()] == [
        f"ball: {k}/200 steps ({p} %)" for k, p in ((50, 25), (100, 50), (150, 75), (200, 100))]
    stream = io.StringIO()
    with contextlib.redirect_stderr(stream):
        output.run(make_scene(steps=200), progress=False)
    assert stream.getvalue() == ""
