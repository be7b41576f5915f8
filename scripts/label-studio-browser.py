"""Open a Label Studio task in a real (headless) browser: screenshot, optionally paint.

    /opt/lsvenv/bin/python scripts/label-studio-browser.py URL/projects/P/data?task=T out.png \
        --user EMAIL --password PASSWORD [--paint LABEL] [--submit]

Runs in Label Studio's own virtual environment with Playwright
(``/opt/lsvenv/bin/pip install playwright``) and Debian's Chromium
(``apt-get install chromium``). Logs in, opens the task and saves a screenshot;
``--paint LABEL`` selects that brush label and paints a horizontal stroke across the
middle of the image (the front end encodes it as brush RLE), ``--submit`` submits the
annotation. Used for docs/figures/label-studio-batch.png and for the recorded export
whose brush region the browser painted (tests/fixtures/label_studio).
"""

from __future__ import annotations

import argparse
import time
from urllib.parse import urlsplit

from playwright.sync_api import sync_playwright

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url", help="the task's page, e.g. .../projects/1/data?task=2")
    parser.add_argument("out", help="screenshot (PNG)")
    parser.add_argument("--user", required=True)
    parser.add_argument("--password", required=True)
    parser.add_argument("--paint", help="brush label to paint a stroke with")
    parser.add_argument("--submit", action="store_true")
    parser.add_argument("--width", type=int, default=1200)
    parser.add_argument("--height", type=int, default=760)
    args = parser.parse_args()
    base = "{0.scheme}://{0.netloc}".format(urlsplit(args.url))
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": args.width, "height": args.height})
        page.goto(f"{base}/user/login/")
        page.fill("input[name=email]", args.user)
        page.fill("input[name=password]", args.password)
        page.click("button[type=submit]")
        page.wait_for_load_state("networkidle")
        page.goto(args.url)
        page.wait_for_load_state("networkidle")
        page.wait_for_selector("canvas", timeout=60_000)
        time.sleep(3)
        if args.paint:
            page.get_by_text(args.paint, exact=True).first.click()
            box = page.locator("canvas").first.bounding_box()
            y = box["y"] + box["height"] * 0.5
            page.mouse.move(box["x"] + box["width"] * 0.2, y)
            page.mouse.down()
            for k in range(1, 21):
                page.mouse.move(box["x"] + box["width"] * (0.2 + 0.03 * k), y)
            page.mouse.up()
            time.sleep(1)
        page.screenshot(path=args.out)
        if args.submit:
            page.get_by_role("button", name="Submit").click()
            page.wait_for_load_state("networkidle")
            time.sleep(2)
        browser.close()


if __name__ == "__main__":
    main()
