"""Progress bars on stderr that suit where stderr goes.

On a terminal, ``bar(...)`` is a tqdm bar, redrawn in place. Anywhere else (a CI log, a pipe, a
file) a redrawn bar would write one carriage-return line per refresh, hundreds in a long run, so
``bar`` gives ``Lines`` instead: a plain line when a quarter of the total is reached (and for each
new stage a caller names with ``set_postfix_str``), one at the end, nothing at all when the work
ends within ``delay`` seconds. Both answer ``update``, ``set_postfix_str``, ``refresh``, ``close``,
``n`` and ``total``, and both are context managers.
"""

from __future__ import annotations

import sys
import time


def is_terminal(file) -> bool:
    """Whether ``file`` (a stream) is a terminal; False for anything without ``isatty``."""
    try:
        return bool(file.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def bar(total: float, desc: str, unit: str = "it", *, file=None, delay: float = 0.0, bar_format: str | None = None,
        leave: bool = True):
    """A progress bar of ``total`` ``unit`` labelled ``desc`` on ``file`` (default: sys.stderr, as
    it is when the bar starts): tqdm's on a terminal, ``Lines`` elsewhere. Nothing shows before
    ``delay`` seconds have passed; ``bar_format`` and ``leave`` are tqdm's (ignored by ``Lines``)."""
    file = sys.stderr if file is None else file
    if is_terminal(file):
        from tqdm import tqdm

        return tqdm(total=total, desc=desc, unit=unit, file=file, delay=delay, leave=leave,
                    **({"bar_format": bar_format} if bar_format else {}))
    return Lines(total, desc, unit, file=file, delay=delay)


class Lines:
    """A progress report for a stream that is not a terminal: ``desc: n/total unit (p %) [t s], postfix``
    lines, one when each quarter of the total is first reached, one for each new postfix (a stage,
    such as CoACD's rounds), and a last one at ``close`` when any was printed; none before ``delay``
    seconds (s) have passed, so short work prints nothing."""

    def __init__(self, total: float, desc: str, unit: str = "it", *, file=None, delay: float = 0.0):
        self.total, self.n = total, 0
        self.desc, self.unit = desc, unit
        self.file = sys.stderr if file is None else file
        self.delay = delay
        self.start = time.monotonic()
        self.postfix = ""
        self.quarter = 0  # the highest quarter of the total reached (0 to 4)
        self.shown = None  # (quarter up to 3, postfix) of the last line printed
        self.last = None  # (count, postfix) of the last line printed

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def _fraction(self) -> float:
        return min(self.n / self.total, 1.0) if self.total else 0.0

    def _print(self) -> None:
        elapsed = time.monotonic() - self.start
        total = f"{self.total:g}" if self.total else "?"
        unit = self.unit + ("s" if self.unit.isalpha() and not self.unit.endswith("s") else "")
        line = f"{self.desc}: {self.n:g}/{total} {unit} ({100.0 * self._fraction():.0f} %) [{elapsed:.0f} s]"
        print(line + (f", {self.postfix}" if self.postfix else ""), file=self.file, flush=True)
        self.last = (self.n, self.total, self.postfix)

    def refresh(self) -> None:
        """Prints a line when a new quarter of the total has been reached or the postfix is new (once
        ``delay`` has passed)."""
        self.quarter = max(self.quarter, int(4 * self._fraction() + 1e-9))
        if self.file is None or time.monotonic() - self.start < self.delay:
            return
        key = (min(self.quarter, 3), self.postfix)
        if key != self.shown and (key[0] > 0 or self.postfix):
            self.shown = key
            self._print()

    def update(self, n: float = 1) -> None:
        self.n += n
        self.refresh()

    def set_postfix_str(self, text: str = "", refresh: bool = True) -> None:
        self.postfix = str(text)
        if refresh:
            self.refresh()

    def close(self) -> None:
        """The last line (the count reached), when a line was printed before or ``delay`` has passed,
        unless the last line printed says the same."""
        if self.file is None:
            return
        if self.last is not None or time.monotonic() - self.start >= self.delay:
            if self.last != (self.n, self.total, self.postfix):
                self._print()
        self.file = None
