"""The page in a real browser (make test-browser; marker `browser`): Debian's Chromium,
headless, driven by Playwright against a real daemon on the simulated hand. The page loads,
its plots advance with the daemon's clock, the E-stop button vents the hand (ESTOP on the
page and through the API), a wrong token is refused, and a screenshot is taken (written to
docs/img/view.png only by `make screenshot`, which sets SCREENSHOT_TO: a test run leaves the
checkout as it was). The page logs no console error and no request of it fails; each finger
has a tracking-error plot; every plot's axes are labelled and its traces differ in colour or
dash, with a legend; a button is enabled only in the states that accept it."""

from __future__ import annotations

import importlib.util
import os
import shutil
import threading
import time
from pathlib import Path
from types import ModuleType

import pytest

from tests.browser.viewproc import CHROMIUM, FLAGS, ViewProcess, started_daemon, sweep, wait_state

pytestmark = pytest.mark.browser

SCREENSHOT_TO = os.environ.get("SCREENSHOT_TO")  # where `make screenshot` wants the page


def browser_driver() -> ModuleType:
    """Playwright and Debian's Chromium, which `make test-browser` installs: missing, a failure."""
    if importlib.util.find_spec("playwright") is None or not Path(CHROMIUM).exists():
        pytest.fail(f"Playwright or {CHROMIUM} is missing: `make test-browser` installs both")
    import playwright.sync_api

    return playwright.sync_api


def test_the_page_plots_live_and_its_estop_vents_the_hand(tmp_path: Path) -> None:
    playwright = browser_driver()
    daemon, hand = started_daemon(tmp_path, realtime=True)  # as deployed: SCHED_FIFO if permitted
    view = None
    stop = threading.Event()
    mover = threading.Thread(target=sweep, args=(daemon.socket, stop), daemon=True)
    try:
        view = ViewProcess(daemon, tmp_path)
        hand.arm()
        hand.target("all", angle_deg=30.0)
        hand.start()
        mover.start()
        with playwright.sync_playwright() as p:
            context = p.chromium.launch_persistent_context(
                str(tmp_path / "chromium-profile"), executable_path=CHROMIUM, headless=True,
                args=FLAGS, viewport={"width": 1400, "height": 1000},
                bypass_csp=True)  # the page's CSP forbids eval; the test evaluates its probes
            try:
                page = context.new_page()
                problems: list[str] = []
                page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}")
                        if m.type == "error" else None)
                page.on("pageerror", lambda exc: problems.append(f"page error: {exc}"))
                page.on("response", lambda r: problems.append(f"HTTP {r.status} {r.url}")
                        if r.status >= 400 else None)
                page.on("requestfailed", lambda r: problems.append(f"failed {r.url}: {r.failure}"))
                page.goto(f"{view.url}#code={view.code}")
                page.wait_for_function("window.hsView && window.hsView.auth === 'ok'", timeout=20_000)
                assert "code" not in page.url  # the link's code left the address bar
                page.wait_for_function("window.hsView.frames > 10 && window.hsView.draws > 5",
                                       timeout=20_000)
                assert page.locator("section.finger").count() == 5
                assert page.locator("section.finger canvas").count() == 20  # 5 fingers x 4 plots
                assert page.locator("section.finger [data-quantity='tracking error']").count() == 5
                assert page.locator("section.finger .u-legend").count() == 20
                assert page.evaluate("hsView.plots.every((p) => p.plot.axes[0].label === 't (s)' && "
                                     "p.plot.axes[1].label.endsWith('(' + p.spec.unit + ')'))")
                assert page.evaluate("hsView.plots.every((p) => new Set(p.spec.series.map("
                                     "([, , colour, dash]) => colour + JSON.stringify(dash))).size === "
                                     "p.spec.series.length)")
                before = page.evaluate("[hsView.lastT, hsView.draws, hsView.plots[0].plot.scales.x.max]")
                time.sleep(1.5)
                after = page.evaluate("[hsView.lastT, hsView.draws, hsView.plots[0].plot.scales.x.max]")
                assert after[0] - before[0] > 0.5, (before, after)  # the daemon's time, 1.5 s later
                assert after[1] > before[1] and after[2] > before[2]  # redrawn, and scrolled
                assert page.locator("#state").inner_text() == "RUNNING"
                enabled = ("Array.from(document.querySelectorAll('#buttons button:enabled'), "
                           "(b) => b.dataset.button)")
                assert sorted(page.evaluate(enabled)) == ["disarm", "hold"]
                time.sleep(6.0)  # the sweep's steps fill the plots' 10 s
                page.screenshot(path=str(tmp_path / "view.png"), full_page=True)
                if SCREENSHOT_TO:
                    shutil.copyfile(tmp_path / "view.png", SCREENSHOT_TO)

                assert page.locator("#estop").is_visible()
                page.mouse.wheel(0, 5000)  # scrolled down, the E-stop stays in view
                assert page.locator("#estop").is_visible()
                page.click("#estop")
                page.wait_for_function("document.getElementById('state').textContent === 'ESTOP'",
                                       timeout=10_000)
                page.wait_for_function("document.querySelector('[data-button=reset]').disabled === false",
                                       timeout=10_000)
                assert page.evaluate(enabled) == ["reset"] and page.locator("#estop").is_enabled()
                assert problems == [], problems
                status = wait_state(hand, "ESTOP")
                assert status["state"] == "ESTOP"
                assert all(f["mode"] == "vent" and f["pressure_cmd_kpa"] == 0.0
                           for f in status["fingers"].values())

                wrong = context.new_page()
                wrong.goto(f"{view.url}#token={'0' * 64}")
                wrong.wait_for_function("document.body.dataset.auth === 'refused'", timeout=20_000)
                assert "refused" in wrong.locator("#message").inner_text()
                assert wrong.evaluate("hsView.frames") == 0

                again = context.new_page()  # the link's code was spent by the first page
                again.goto(f"{view.url}#code={view.code}")
                again.wait_for_function("!document.getElementById('login').hidden", timeout=20_000)
                assert again.evaluate("hsView.token") is None and again.evaluate("hsView.frames") == 0
            finally:
                context.close()
    finally:
        stop.set()
        if mover.is_alive():  # its requests in flight end before the daemon does (else a reset)
            mover.join(10)
        if view is not None:
            view.close()
        daemon.close()
    assert (tmp_path / "view.png").stat().st_size > 10_000
