"""The README's picture of the browser app: docs/img/app.png.

    python3 examples/app_screenshot.py [--out docs/img/app.png]

Starts the app on a free port, opens it in headless Chromium (the system's,
``/usr/bin/chromium``; Playwright from ``pip install -e .[test]``), picks the
crank-rocker four-bar, simulates 3 s, stops the animation at 1.2 s and takes
the picture.
"""

import argparse
import shutil
import tempfile
import threading
from pathlib import Path

from playwright.sync_api import sync_playwright

from grubler.app.server import AppServer

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "img" / "app.png"))
    args = ap.parse_args()
    server = AppServer("127.0.0.1", 0, tempfile.mkdtemp(prefix="grubler-shot-"))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=shutil.which("chromium") or "/usr/bin/chromium",
                                    args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1400, "height": 1180})
        page.goto(server.url)
        page.wait_for_selector("circle.handle")
        page.select_option("#preset", "fourbar-crank-rocker")
        page.wait_for_timeout(500)
        page.fill("#t_end", "3")
        page.click("#simulate")
        page.wait_for_selector("#panels svg path")
        page.click("#play")
        page.eval_on_selector("#scrub", "(e) => { e.value = 1.2; e.dispatchEvent(new Event('input')); }")
        page.wait_for_timeout(300)
        page.screenshot(path=args.out)
        browser.close()
    server.shutdown()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
