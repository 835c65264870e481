#!/usr/bin/env python3
"""Open scanrig's self-contained HTML pages in headless Chromium and check that they work.

    python3 check_pages.py --out DIR [--screenshot-width 1280 --screenshot-height 900] PAGE.html...

Per page: no console errors, uncaught exceptions or failed requests (the pages must work offline,
from file://); `window.scanrigReady` becomes true within 60 s when the page sets
`window.scanrigExpectsReady`; every visible `canvas.viewer-canvas` has drawn something; every <img>
loaded; every local link and #anchor resolves. Screenshots go to DIR/<stem>.png and, for pages
with a viewer, DIR/<stem>.viewer.png. A click at the viewer's centre must answer in #viewer-pick
(the text is in the summary's "pick"). Buttons with data-test="toggle" (one per viewer layer) are
all switched off, then each layer is shown alone, checked to draw, and shot as
DIR/<stem>.viewer.<k>.png.

stdout: a JSON list, one summary per page. stderr: human-readable lines.
Exit status: 0 all pages pass, 1 some page failed (or bad usage), 2 Playwright, Pillow or Chromium
is not installed -- so a caller can tell "cannot check here" from "checked and failed".

Needs Debian's chromium (`apt-get install chromium`) and
`python3 -m pip install playwright==1.65.2 pillow==13.0.0`; Playwright's own browser download is
never used (it cannot reach its download host on the project's machines).
"""

import argparse
import io
import json
import os
import sys
import time
from functools import reduce
from pathlib import Path
from urllib.parse import unquote, urljoin, urlsplit
from urllib.request import url2pathname

try:
    from PIL import Image, ImageChops
    from playwright.sync_api import Error as PlaywrightError
    from playwright.sync_api import TimeoutError as PlaywrightTimeout
    from playwright.sync_api import sync_playwright
except ImportError as missing:
    print(
        f"check_pages: Python package {missing.name!r} is not installed; "
        "run: python3 -m pip install playwright==1.65.2 pillow==13.0.0",
        file=sys.stderr,
    )
    sys.exit(2)

CHROMIUM = "/usr/bin/chromium"
# SwiftShader gives WebGL without a GPU. The networking flags stop Chromium's own background
# traffic, which on a machine without internet access only produces noise and delays.
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-quic",
]
READY_TIMEOUT_MS = 60_000
CLICK_TIMEOUT_MS = 5_000
SETTLE_AFTER_CLICK_MS = 300
# A viewer whose picture is (nearly) all background did not render: 0.5 % of its pixels must differ
# from the background by more than CHANNEL_TOLERANCE in some channel (anti-aliasing and SwiftShader
# rounding stay well below it).
MIN_DRAWN_FRACTION = 0.005
MIN_LAYER_PIXELS = 50
CHANNEL_TOLERANCE = 8
# Warnings that the checker itself provokes (SwiftShader reading back the canvas for a screenshot),
# not the page.
OWN_WARNINGS = ("GPU stall due to ReadPixels",)


def short(url):
    """Data URLs can be megabytes long; a message only needs their start."""
    return url[:60] + "..." if url.startswith("data:") and len(url) > 60 else url


def parse_hex_colour(text):
    digits = text.strip().lstrip("#")
    if len(digits) == 3:
        digits = "".join(d * 2 for d in digits)
    if len(digits) != 6:
        raise ValueError(f"data-background {text!r} is not a #rgb or #rrggbb colour")
    return tuple(int(digits[i : i + 2], 16) for i in (0, 2, 4))


def count_drawn(png, background):
    """Pixels of the PNG that differ from `background` (or, if None, its most common colour)."""
    rgb = Image.open(io.BytesIO(png)).convert("RGB")
    if background is None:
        background = max(rgb.getcolors(rgb.width * rgb.height))[1]
    difference = ImageChops.difference(rgb, Image.new("RGB", rgb.size, background))
    largest_channel = reduce(ImageChops.lighter, difference.split())
    drawn = sum(largest_channel.histogram()[CHANNEL_TOLERANCE + 1 :])
    return drawn, rgb.width * rgb.height


def check_viewers(page, when, errors, min_fraction=None):
    """Screenshot and measure every visible viewer canvas; `when` names the moment in messages.
    A whole scene must fill MIN_DRAWN_FRACTION of the canvas; one layer alone (a single line, say)
    need only draw MIN_LAYER_PIXELS."""
    results = []
    for index, canvas in enumerate(page.query_selector_all("canvas.viewer-canvas")):
        name = "#" + canvas.get_attribute("id") if canvas.get_attribute("id") else f"viewer-canvas {index}"
        # Canvases in collapsed sections have nothing to show; pages may also opt a canvas out.
        if canvas.get_attribute("data-check") == "skip" or not canvas.is_visible():
            continue
        try:
            background = canvas.get_attribute("data-background")
            drawn, total = count_drawn(canvas.screenshot(), background and parse_hex_colour(background))
        except ValueError as error:
            errors.append(f"canvas {name} ({when}): {error}")
            continue
        fraction = drawn / total if total else 0.0
        results.append({"canvas": name, "when": when, "drawn_pixels": drawn, "fraction": round(fraction, 5)})
        if min_fraction is None and fraction < MIN_DRAWN_FRACTION:
            errors.append(
                f"canvas {name} ({when}): only {drawn} of {total} pixels drawn ({fraction:.2%}, "
                f"need {MIN_DRAWN_FRACTION:.1%})"
            )
        elif min_fraction is not None and drawn < MIN_LAYER_PIXELS:
            errors.append(f"canvas {name} ({when}): only {drawn} pixels drawn with this layer alone")
    return results


# A lazy image loads only near the viewport, so one in a collapsed section never would: switching
# it to eager loads it wherever it is, which is what matters (its file is there and decodes).
IMAGES_JS = """async () => {
    const result = [];
    for (const img of document.images) {
        if (!img.complete) {
            img.loading = "eager";
            await new Promise(done => {
                img.addEventListener("load", done, {once: true});
                img.addEventListener("error", done, {once: true});
                setTimeout(done, 10000);
            });
        }
        result.push({src: img.getAttribute("src") || "", ok: img.complete && img.naturalWidth > 0});
    }
    return result;
}"""


def check_images(page, errors):
    images = page.evaluate(IMAGES_JS)
    errors.extend(f"image did not load: {short(img['src']) or '(no src)'}" for img in images if not img["ok"])
    return len(images)


def check_links(page, page_url, errors, warnings):
    """Returns (links checked, http(s) links). Pages are offline documents: links must stay local."""
    links = page.eval_on_selector_all("a[href]", "links => links.map(a => a.getAttribute('href'))")
    http_links = 0
    for href in links:
        if href.startswith("#"):
            target = unquote(href[1:])
            if target and not page.evaluate("id => document.getElementById(id) !== null", target):
                errors.append(f"link {href}: no element with id {target!r}")
            continue
        url = urlsplit(urljoin(page_url, href))
        if url.scheme in ("data", "blob"):
            continue
        if url.scheme in ("http", "https"):
            http_links += 1
            warnings.append(f"link to the web (not checked): {href}")
        elif url.scheme != "file":
            warnings.append(f"link with scheme {url.scheme!r} not checked: {short(href)}")
        elif url.netloc not in ("", "localhost"):
            errors.append(f"link {href}: points at host {url.netloc!r}, not a local file")
        elif not os.path.exists(url2pathname(url.path)):
            errors.append(f"link {short(href)}: {url2pathname(url.path)} does not exist")
    return len(links), http_links


def on_console(msg, errors, warnings):
    if msg.type == "error" or (msg.type == "warning" and not any(w in msg.text for w in OWN_WARNINGS)):
        where = f"{short(msg.location.get('url', '?'))}:{msg.location.get('lineNumber', '?')}"
        (errors if msg.type == "error" else warnings).append(f"console {msg.type}: {msg.text} ({where})")


def visit(page, path, out_dir, summary):
    errors, warnings = summary["errors"], summary["warnings"]
    # Listeners stay on for the whole visit, so errors raised by the toggle clicks count too.
    page.on("console", lambda msg: on_console(msg, errors, warnings))
    page.on("pageerror", lambda exc: errors.append(f"uncaught exception: {exc}"))
    page.on("requestfailed", lambda req: errors.append(f"request failed: {short(req.url)} ({req.failure})"))
    page.on("crash", lambda _: errors.append("the page crashed"))

    started = time.perf_counter()
    page.goto(path.as_uri(), wait_until="load", timeout=READY_TIMEOUT_MS)
    try:
        if page.evaluate("window.scanrigExpectsReady === true"):
            page.wait_for_function("window.scanrigReady === true", timeout=READY_TIMEOUT_MS)
        summary["open_seconds"] = round(time.perf_counter() - started, 3)
    except PlaywrightTimeout:
        # Go on: the other checks still tell what state the page is stuck in.
        errors.append(f"window.scanrigReady was not true {READY_TIMEOUT_MS // 1000} s after load")

    summary["canvases"] = check_viewers(page, "after load", errors)
    summary["images"] = check_images(page, errors)
    summary["links_checked"], summary["http_links"] = check_links(page, path.as_uri(), errors, warnings)

    full_shot = out_dir / f"{path.stem}.png"
    page.screenshot(path=full_shot, full_page=True)
    summary["screenshots"].append(str(full_shot))
    viewer = next((v for v in page.query_selector_all("#viewer, .viewer-canvas") if v.is_visible()), None)
    if viewer:
        viewer_shot = out_dir / f"{path.stem}.viewer.png"
        viewer.evaluate_handle("v => v.parentElement").as_element().screenshot(path=viewer_shot)
        summary["screenshots"].append(str(viewer_shot))

    # Picking: a click at the canvas' centre (the scene's centre, where the first layer usually is)
    # must answer in #viewer-pick, with coordinates or with "nothing under the cursor".
    pick = page.query_selector("#viewer-pick")
    if viewer and pick:
        before = pick.text_content()
        box = page.query_selector(".viewer-canvas").bounding_box()
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.wait_for_timeout(SETTLE_AFTER_CLICK_MS)
        summary["pick"] = pick.text_content()
        if summary["pick"] == before:
            errors.append("a click on the canvas did not answer in #viewer-pick")

    # Each layer alone: every toggle off first, then each on by itself (its code path, its pixels),
    # shot as DIR/<stem>.viewer.<k>.png, and off again.
    buttons = page.query_selector_all('button[data-test="toggle"]')
    for button in buttons:
        if button.is_visible() and button.get_attribute("aria-pressed") == "true":
            button.click(timeout=CLICK_TIMEOUT_MS)
    for index, button in enumerate(buttons):
        label = f"toggle {index} {(button.text_content() or '').strip()!r}"
        if not button.is_visible():
            warnings.append(f"{label} is hidden, not clicked")
            continue
        button.click(timeout=CLICK_TIMEOUT_MS)
        page.wait_for_timeout(SETTLE_AFTER_CLICK_MS)
        summary["canvases"] += check_viewers(page, f"{label} alone", errors, min_fraction=0)
        if viewer:
            layer_shot = out_dir / f"{path.stem}.viewer.{index}.png"
            viewer.evaluate_handle("v => v.parentElement").as_element().screenshot(path=layer_shot)
            summary["screenshots"].append(str(layer_shot))
        button.click(timeout=CLICK_TIMEOUT_MS)


def check_page(browser, page_path, out_dir, viewport):
    path = Path(page_path).resolve()
    summary = {"page": page_path, "open_seconds": None, "bytes": None, "pick": None, "canvases": [], "images": 0,
               "links_checked": 0, "http_links": 0, "screenshots": [], "errors": [], "warnings": []}
    if not path.is_file():
        summary["errors"].append(f"no such file: {path}")
        return summary
    summary["bytes"] = path.stat().st_size

    try:
        with browser.new_context(viewport=viewport) as context:
            visit(context.new_page(), path, out_dir, summary)
    except PlaywrightError as error:
        # One broken page (or a timeout) must not hide the results of the others.
        summary["errors"].append(f"browser: {error.message.splitlines()[0]}")
    return summary


def report(summary):
    name = summary["page"]
    if summary["open_seconds"] is not None:
        print(f"{name}: opened in {summary['open_seconds']:.2f} s", file=sys.stderr)
    for canvas in summary["canvases"]:
        print(f"{name}: canvas {canvas['canvas']} ({canvas['when']}): {canvas['drawn_pixels']} pixels drawn "
              f"({canvas['fraction']:.2%})", file=sys.stderr)
    print(f"{name}: {summary['images']} images, {summary['links_checked']} links "
          f"({summary['http_links']} to the web)", file=sys.stderr)
    for warning in summary["warnings"]:
        print(f"{name}: warning: {warning}", file=sys.stderr)
    for error in summary["errors"]:
        print(f"{name}: ERROR: {error}", file=sys.stderr)
    print(f"{name}: {'FAILED' if summary['errors'] else 'ok'}", file=sys.stderr)


class Parser(argparse.ArgumentParser):
    def error(self, message):
        # argparse would exit 2, which here means "not installed"; bad usage is a failure.
        self.print_usage(sys.stderr)
        print(f"check_pages: {message}", file=sys.stderr)
        sys.exit(1)


def main():
    parser = Parser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, type=Path, help="folder for the screenshots")
    parser.add_argument("--screenshot-width", type=int, default=1280)
    parser.add_argument("--screenshot-height", type=int, default=900)
    parser.add_argument("pages", nargs="+", metavar="PAGE.html")
    args = parser.parse_args()
    stems = [Path(p).stem for p in args.pages]
    if len(set(stems)) != len(stems):
        parser.error("two pages share a file name stem, so their screenshots would overwrite each other")

    if not os.access(CHROMIUM, os.X_OK):
        print(f"check_pages: {CHROMIUM} not found; run: apt-get install -y chromium", file=sys.stderr)
        sys.exit(2)
    args.out.mkdir(parents=True, exist_ok=True)
    viewport = {"width": args.screenshot_width, "height": args.screenshot_height}

    with sync_playwright() as playwright:
        try:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        except PlaywrightError as error:
            # Installed but unable to start: a real failure, not "not installed".
            print(f"check_pages: {CHROMIUM} did not start:\n{error.message}", file=sys.stderr)
            sys.exit(1)
        summaries = []
        for page_path in args.pages:
            summaries.append(check_page(browser, page_path, args.out, viewport))
            report(summaries[-1])
        browser.close()

    json.dump(summaries, sys.stdout, indent=2)
    print()
    failed = sum(1 for s in summaries if s["errors"])
    print(f"check_pages: {len(summaries)} pages checked, {failed} with errors", file=sys.stderr)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
