"""Headless Chromium for the tests: Debian's ``chromium`` driven by Playwright (PyPI), never a
browser downloaded by Playwright. ``scripts/install.sh`` installs both.

``chromium_path()`` finds the browser ($SIGNORINI_CHROMIUM, else ``chromium`` on PATH) or fails
the test with what to install; ``launch(playwright)`` starts it headless with WebGL on SwiftShader
(software rendering: the same pixels on every machine, no GPU needed).
"""

import os
import shutil

import pytest


def chromium_path() -> str:
    path = os.environ.get("SIGNORINI_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    if not path:
        pytest.fail("headless Chromium not found: run scripts/install.sh (apt-get install chromium) "
                    "or set SIGNORINI_CHROMIUM to a Chromium binary")
    return path


def launch(playwright):
    return playwright.chromium.launch(
        executable_path=chromium_path(), headless=True,
        args=["--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--ignore-gpu-blocklist"],
    )
