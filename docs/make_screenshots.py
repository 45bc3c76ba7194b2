"""Regenerate the README's inspector screenshots: ``docs/img/inspector-main.png`` and
``docs/img/inspector-object.png``.

The inspector runs on the built-in demo pair (512 px, scenario ``mixed``, seed 0) with the
``radcons`` preset, in headless Chromium (Debian's ``/usr/bin/chromium`` through
Playwright) at 1600 x 1000: first the main screen as it opens, then the drill-down of one
object, chosen in the Objects tab's dropdown.

Usage::

    python docs/make_screenshots.py [--object 24] [--out docs/img]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from inspector.app import InspectorApp

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"]
#: Seconds left to the page to draw what it was sent before each screenshot.
SETTLE = 3.0
#: Closes the page's notifications (headless Chromium's software WebGL gets a warning).
CLOSE_NOTIFICATIONS = "document.querySelectorAll('.mantine-Notification-closeButton').forEach((b) => b.click())"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", type=int, default=24, help="reference object id of the drill-down")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "img", help="folder of the images")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as folder, sync_playwright() as playwright:
        app = InspectorApp(port=0, record_dir=Path(folder) / "rec", preset="radcons").start()
        context = playwright.chromium.launch_persistent_context(
            str(Path(folder) / "profile"), executable_path="/usr/bin/chromium", headless=True, args=CHROMIUM_ARGS,
            viewport={"width": 1600, "height": 1000},
        )
        try:
            if not app.wait_idle(600):
                raise SystemExit("the inspector did not finish its first run within 600 s")
            page = context.new_page()
            page.goto(app.url)
            page.get_by_text("Ready · computed", exact=False).first.wait_for(timeout=300_000)
            time.sleep(SETTLE)
            page.evaluate(CLOSE_NOTIFICATIONS)
            time.sleep(SETTLE)
            page.screenshot(path=str(args.out / "inspector-main.png"))
            app.select_object(args.object)
            page.get_by_role("heading", name=f"Object {args.object}").wait_for(timeout=60_000)
            app.wait_idle(120)
            time.sleep(SETTLE)
            page.screenshot(path=str(args.out / "inspector-object.png"))
        finally:
            context.close()
            app.stop()
    print(f"wrote {args.out / 'inspector-main.png'} and {args.out / 'inspector-object.png'}")


if __name__ == "__main__":
    main()
