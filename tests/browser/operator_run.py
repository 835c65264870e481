#!/usr/bin/env python3
"""An operator's whole run at `scanrig serve`, in headless Chromium: check, calibrate, scan (with the
turntable unplugged mid-scan and the scan resumed), process, report, projects.

    python3 operator_run.py --url http://127.0.0.1:PORT/ --out DIR [--views 12] [--project scan1]
                            [--unplug-after 4]

A second browser opens the station too and must be refused control (read-only). Screenshots of each
screen go to DIR/<screen>.png. Every console error, uncaught exception or failed request of either
browser is collected. stdout: one JSON summary (what the caller asserts on):
  lags_ms       each view's time from its capture to its points drawn in the 3D view, by view
  clicks_ms     the Projects button's answers while processing ran
  check         the check's verdicts
  calibrated    the calibration's message
  fault         what the page said when the turntable was unplugged
  errors        console errors, exceptions, failed requests (must be empty)
  screens       the screenshots written
Exit status: 0 the run completed (the caller judges the figures), 1 a step failed, 2 Playwright,
Pillow or Chromium is missing.
"""

import argparse
import json
import re
import sys
import time
from pathlib import Path

try:
    from playwright.sync_api import sync_playwright
except ImportError as missing:
    print(f"operator_run: Python package {missing.name!r} is not installed; "
          "run: python3 -m pip install playwright==1.65.2", file=sys.stderr)
    sys.exit(2)

sys.path.insert(0, str(Path(__file__).parent))
from check_pages import CHROMIUM, CHROMIUM_ARGS  # noqa: E402  (one browser setup for both checkers)

STEP_MS = 180_000


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--views", type=int, default=12)
    ap.add_argument("--project", default="scan1")
    ap.add_argument("--unplug-after", type=int, default=4)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if not Path(CHROMIUM).exists():
        print(f"operator_run: no {CHROMIUM} (apt-get install chromium)", file=sys.stderr)
        sys.exit(2)
    summary = {"errors": [], "screens": []}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            run(browser, args, summary)
        except Exception:
            print_page(summary.pop("page", None), summary)
            raise
        finally:
            browser.close()
    summary.pop("page", None)
    json.dump(summary, sys.stdout, indent=1)
    print()


def print_page(page, summary):
    """What the operator's page showed when a step failed, to stderr: the scan's and the process's
    status, the messages, the badges, the live log's end and the station's state. A timeout alone
    says which wait ran out, not why (CI's log is all there is to go on)."""
    if page is not None:
        try:
            shown = page.evaluate("""async () => {
                const text = (id) => { const e = document.getElementById(id); return e ? e.textContent : null; };
                const scan = document.getElementById('scan-status');
                return {
                    scan: (scan ? scan.dataset.state : null) + ': ' + text('scan-status'),
                    process: text('process-status'),
                    messages: text('messages'),
                    badges: [...document.querySelectorAll('#badges .badge')].map(b => b.textContent),
                    live_log_end: (text('live-log') || '').slice(-3000),
                    station: await fetch('/api/state').then(r => r.json()).catch(e => String(e)),
                };
            }""")
            print("operator_run: the page when the step failed: " + json.dumps(shown, indent=1), file=sys.stderr)
        except Exception as e:  # the page itself may be what failed
            print(f"operator_run: the page could not be read when the step failed: {e}", file=sys.stderr)
    if summary["errors"]:
        print("operator_run: errors seen before: " + json.dumps(summary["errors"], indent=1), file=sys.stderr)


def watch(page, name, summary):
    def console(msg):
        if msg.type == "error":
            summary["errors"].append(f"{name}: console error: {msg.text}")
    page.on("console", console)
    page.on("pageerror", lambda exc: summary["errors"].append(f"{name}: uncaught exception: {exc}"))
    page.on("response", lambda r: summary["errors"].append(f"{name}: {r.status} for {r.url[:100]}")
            if r.status >= 400 else None)
    page.on("requestfailed", lambda req: summary["errors"].append(
        f"{name}: request failed: {req.url[:80]} ({req.failure})"
        # A page closing its event stream is not a failure.
        ) if "/api/events" not in req.url else None)


def shot(page, args, summary, screen):
    path = args.out / f"{screen}.png"
    page.screenshot(path=str(path), full_page=True)
    summary["screens"].append(str(path))
    print(f"operator_run: {screen} shown", file=sys.stderr)


def tab(page, name):
    page.click(f"#tabs a[data-tab={name}]")
    page.wait_for_selector(f"section#{name}:not([hidden])")


def idle(page):
    """Waits until the station runs no job (its state event says so)."""
    page.wait_for_function("() => fetch('/api/state').then(r => r.json()).then(s => !s.job)", timeout=STEP_MS,
                           polling=250)


def run(browser, args, summary):
    operator = browser.new_context(viewport={"width": 1280, "height": 900}).new_page()
    summary["page"] = operator  # for print_page, not the summary's output
    watch(operator, "operator", summary)
    operator.goto(args.url)
    operator.wait_for_selector("body[data-ready=yes]")
    operator.click("#take-control")
    operator.wait_for_function("() => document.getElementById('control-state').textContent.includes('This page controls')")

    # A second browser watches, and is refused control.
    other = browser.new_context(viewport={"width": 1280, "height": 900}).new_page()
    # Its one expected error is the refusal itself (the browser logs a 409 answer to fetch).
    expected = []
    other.on("console", lambda m: (expected if "409" in m.text else summary["errors"]).append(
        f"second browser: console {m.type}: {m.text}") if m.type == "error" else None)
    other.on("pageerror", lambda exc: summary["errors"].append(f"second browser: uncaught exception: {exc}"))
    other.goto(args.url)
    other.wait_for_selector("body[data-ready=yes]")
    other.click("#take-control")
    other.wait_for_selector("#messages div")
    summary["second_controller"] = other.inner_text("#messages div")
    summary["second_buttons_disabled"] = other.eval_on_selector("#check-run", "b => b.disabled")
    summary["second_refusal_logged"] = expected
    shot(other, args, summary, "read-only")

    # Devices and check.
    operator.click("#check-run")
    operator.wait_for_selector("#check-results[data-done=yes]", timeout=STEP_MS)
    summary["check"] = operator.eval_on_selector_all(
        "#check-results li", "ls => ls.map(l => ({name: l.dataset.check, verdict: l.className, text: l.textContent}))")
    shot(operator, args, summary, "devices")

    # Live view: the decoded map, then the board's corners.
    tab(operator, "live")
    # The exposure up, the raw frame; then back, and the decoded map.
    exposure = operator.input_value("#live-exposure")
    operator.fill("#live-exposure", "4")
    operator.click("#live-exposure-set")
    operator.wait_for_function("() => document.getElementById('live-image').src.startsWith('data:image/png')",
                               timeout=STEP_MS)
    operator.wait_for_function("() => document.getElementById('live-warning').textContent.includes('saturated')")
    summary["overexposed"] = operator.inner_text("#live-warning")
    operator.fill("#live-exposure", exposure)
    operator.click("#live-exposure-set")
    operator.wait_for_function("() => document.getElementById('live-warning').textContent === ''")
    operator.select_option("#live-show", "decode")
    operator.click("#live-take")
    operator.wait_for_function("() => document.getElementById('live-note').textContent.startsWith('decoded')",
                               timeout=STEP_MS)
    summary["live_note"] = operator.inner_text("#live-note")
    shot(operator, args, summary, "live")

    # Calibration: each held pose, then the sweep; accept what has a board; calibrate.
    tab(operator, "calibrate")
    for k in range(100):
        if operator.eval_on_selector("#calib-next", "p => p.textContent.includes('every held pose')"):
            break
        idle(operator)
        before = operator.eval_on_selector_all("#calib-captures figure", "f => f.length")
        operator.click("#calib-held")
        operator.wait_for_function(f"() => document.querySelectorAll('#calib-captures figure').length > {before}",
                                   timeout=STEP_MS)
    idle(operator)
    before = operator.eval_on_selector_all("#calib-captures figure", "f => f.length")
    operator.click("#calib-sweep")
    idle(operator)
    sweep = operator.evaluate("() => fetch('/api/calibration').then(r => r.json()).then(w => w.sweep.length)")
    operator.wait_for_function(
        f"() => document.querySelectorAll('#calib-captures figure').length >= {before + sweep}", timeout=STEP_MS)
    operator.click("#calib-accept-all")
    operator.wait_for_selector("#calib-captures[data-reviewed=all]", timeout=STEP_MS)
    summary["captures"] = operator.eval_on_selector_all(
        "#calib-captures figure", "fs => fs.map(f => f.className + ': ' + f.querySelector('figcaption').textContent)")
    operator.click("#calib-run")
    operator.wait_for_selector("#calib-result p", timeout=STEP_MS)
    operator.wait_for_selector("#calib-report", timeout=10_000)
    summary["calibrated"] = operator.inner_text("#calib-result")
    shot(operator, args, summary, "calibrate")

    # Scan, unplugging the turntable after a few views; the page says so; Start resumes.
    tab(operator, "scan")
    operator.fill("#scan-project", args.project)
    operator.fill("#scan-views", str(args.views))
    operator.click("#scan-start")
    operator.wait_for_function(
        f"() => document.querySelectorAll('#badges .badge').length >= {args.unplug_after}", timeout=STEP_MS)
    tab(operator, "devices")
    operator.click("#fault-unplug")
    operator.wait_for_function("() => document.getElementById('scan-status').dataset.state === 'failed'",
                               timeout=STEP_MS)
    # The scan's state and the job's fault (its reason) are two events in that order: the reason may
    # land a moment after the state, so wait for it rather than read the messages at once.
    operator.wait_for_function(
        "() => [...document.querySelectorAll('#messages div')].some(d => d.textContent.startsWith('scan '))",
        timeout=STEP_MS)
    summary["fault"] = {"status": operator.inner_text("#scan-status"), "message": operator.inner_text("#messages")}
    tab(operator, "scan")
    shot(operator, args, summary, "fault")
    idle(operator)
    kept = operator.eval_on_selector_all("#badges .badge", "b => b.length")
    operator.click("#scan-start")
    operator.wait_for_function("() => document.getElementById('scan-status').dataset.state === 'complete'",
                               timeout=STEP_MS)
    summary["views_before_fault"] = kept
    idle(operator)
    # The views before the fault are shown again, then the rest as they land: every view drawn.
    operator.wait_for_function(f"() => document.querySelectorAll('#badges .badge').length >= {args.views}",
                               timeout=STEP_MS)
    shot(operator, args, summary, "scan")

    # Process, clicking Projects' refresh while it runs: each answer is timed in the page.
    operator.click("#process-start")
    operator.wait_for_function("() => document.getElementById('process-status').textContent.includes('of')",
                               timeout=STEP_MS)
    tab(operator, "projects")
    clicks = []
    for _ in range(3):
        operator.wait_for_timeout(400)
        t0 = time.monotonic()
        operator.click("#projects-refresh")
        operator.wait_for_function("() => /answered in/.test(document.getElementById('projects-answered').textContent)")
        clicks.append((time.monotonic() - t0) * 1000)
    summary["clicks_wall_ms"] = clicks
    tab(operator, "scan")
    operator.wait_for_selector("#report-link", timeout=STEP_MS)
    shot(operator, args, summary, "processed")
    log = operator.inner_text("#live-log") if operator.query_selector("#live-log") else ""
    log = operator.eval_on_selector("#live-log", "p => p.textContent")
    # A lag below zero would be the page's clock against the station's, not speed: kept as read.
    summary["lags_ms"] = {int(m.group(1)): int(m.group(2))
                          for m in re.finditer(r"view (\d+) shown (-?\d+) ms after its capture", log)}
    summary["clicks_ms"] = [int(m.group(1)) for m in re.finditer(r"projects answered in (\d+) ms during process", log)]
    summary["downloads"] = operator.eval_on_selector_all("#process-result a.download", "as => as.map(a => a.textContent)")

    # The report page, from the station.
    with operator.context.expect_page() as opened:
        operator.click("#report-link")
    report = opened.value
    watch(report, "report page", summary)
    report.wait_for_load_state("load")
    report.wait_for_function("() => window.scanrigReady === true", timeout=STEP_MS)
    shot(report, args, summary, "report")
    report.close()

    tab(operator, "projects")
    operator.wait_for_selector(f"#projects-table tr[data-project={args.project}]")
    shot(operator, args, summary, "projects")

    # The operator's page sits idle past the station's --control-timeout (5 s in this run): it keeps
    # control by answering the station's pings, and the second browser, asking again, is refused.
    operator.wait_for_timeout(7000)
    other.evaluate("() => document.getElementById('messages').replaceChildren()")
    other.click("#take-control")
    other.wait_for_selector("#messages div")
    summary["second_controller_after_idle"] = other.inner_text("#messages div")
    summary["operator_after_idle"] = operator.inner_text("#control-state")


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # a step that failed: say which, for the caller's assertion message
        print(f"operator_run: {type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(1)
