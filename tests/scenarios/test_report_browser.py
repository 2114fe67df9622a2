"""The report in headless Chromium: it renders, every image decodes, no console error.

Chromium (Debian's ``chromium``) is driven over the DevTools protocol on a pipe
(``--remote-debugging-pipe``: NUL-terminated JSON on fds 3 and 4), with the
standard library only. The page itself has no script; the test evaluates one
expression in it after the load event to count images that did not decode.

Skipped only when ``/usr/bin/chromium`` is missing and ``CI`` is unset; under
CI a missing browser fails (``.ci/run`` installs it).
"""

from __future__ import annotations

import base64
import fcntl
import io
import json
import os
import re
import select
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import matplotlib.image
import pytest
from scipy import stats
from test_report import CREATED, reproduction_json, store_path  # noqa: F401 (fixtures)

from scenarios.report import build_report
from scenarios.store import ResultStore

CHROMIUM = Path("/usr/bin/chromium")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--remote-debugging-pipe")
TIMEOUT_S = 60.0

if not CHROMIUM.exists():
    if os.environ.get("CI"):
        pytest.fail(f"{CHROMIUM} is missing under CI (expected .ci/run to install chromium)",
                    pytrace=False)
    pytest.skip(f"{CHROMIUM} not installed (apt-get install chromium); CI is unset",
                allow_module_level=True)


def _high_fd(fd: int) -> int:
    """A duplicate of ``fd`` numbered 10 or more (not inherited); closes ``fd``."""
    high = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
    os.close(fd)
    return high


class DevTools:
    """A minimal DevTools-protocol client over Chromium's debugging pipe.

    Parameters
    ----------
    user_data_dir : Path
        A new, empty profile directory.
    """

    def __init__(self, user_data_dir: Path) -> None:
        to_browser_r, self._write_fd = os.pipe()
        self._read_fd, from_browser_w = os.pipe()
        # move the child's ends above 4, then let the child put them on 3 and 4
        to_browser_r, from_browser_w = (_high_fd(to_browser_r), _high_fd(from_browser_w))

        def on_3_and_4() -> None:  # runs in the child between fork and exec
            os.dup2(to_browser_r, 3)
            os.dup2(from_browser_w, 4)

        # stderr to a file: Chromium logs D-Bus noise that could fill a pipe and block it
        self._stderr = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(
            [str(CHROMIUM), *FLAGS, f"--user-data-dir={user_data_dir}"],
            preexec_fn=on_3_and_4, close_fds=False, stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=self._stderr,
        )
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._buffer = b""
        self._next_id = 0
        self.events: list[dict[str, Any]] = []
        self.deadline = time.monotonic() + TIMEOUT_S

    def _read_message(self) -> dict[str, Any]:
        while b"\0" not in self._buffer:
            left = self.deadline - time.monotonic()
            ready, _, _ = select.select([self._read_fd], [], [], max(left, 0.0))
            if not ready:
                raise TimeoutError(f"no DevTools message within {TIMEOUT_S:g} s")
            chunk = os.read(self._read_fd, 1 << 20)
            if not chunk:
                raise ConnectionError(f"Chromium closed the debugging pipe: {self.stderr_tail()}")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method: str, session: str | None = None, **params: Any) -> dict[str, Any]:
        """Send one command and return its result; events seen meanwhile go to ``events``."""
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params}
        if session is not None:
            message["sessionId"] = session
        os.write(self._write_fd, json.dumps(message).encode() + b"\0")
        while True:
            reply = self._read_message()
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]
            self.events.append(reply)

    def wait_event(self, method: str) -> dict[str, Any]:
        """Block until the event ``method`` arrives (or was already seen)."""
        for event in self.events:
            if event.get("method") == method:
                return event
        while True:
            event = self._read_message()
            self.events.append(event)
            if event.get("method") == method:
                return event

    def stderr_tail(self, n_lines: int = 3) -> list[str]:
        """The last lines Chromium wrote to stderr."""
        self._stderr.seek(0)
        return self._stderr.read().decode(errors="replace").strip().splitlines()[-n_lines:]

    def close(self) -> None:
        """Close the browser (killed if it does not exit within 10 s) and the pipes."""
        try:
            self.call("Browser.close")
        except (OSError, ConnectionError, TimeoutError, RuntimeError):
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self._write_fd)
        os.close(self._read_fd)
        self._stderr.close()


def page_errors(events: list[dict[str, Any]]) -> list[str]:
    """Console errors, uncaught exceptions, error log entries and failed loads."""
    out = []
    for event in events:
        method, params = event.get("method"), event.get("params", {})
        if method == "Runtime.exceptionThrown":
            out.append(f"exception: {params['exceptionDetails'].get('text')}")
        elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
            out.append(f"console.{params['type']}: {params.get('args')}")
        elif method == "Log.entryAdded" and params["entry"].get("level") == "error":
            out.append(f"log: {params['entry'].get('text')} {params['entry'].get('url', '')}")
        elif method == "Network.loadingFailed":
            out.append(f"load failed: {params.get('errorText')}")
    return out


_IMAGES = """JSON.stringify({
  n: document.images.length,
  broken: Array.from(document.images).filter(i => !i.complete || i.naturalWidth === 0).length,
  widths: Array.from(document.images).map(i => i.naturalWidth),
  charts: document.querySelectorAll('svg.chart').length,
  scripts: document.scripts.length,
  sections: document.querySelectorAll('section h2').length,
  height: document.documentElement.scrollHeight,
  first: (document.querySelector('section') || {}).id || null,
  summary: (() => {
    const s = document.querySelector('section#summary');
    if (!s) return null;
    const r = s.getBoundingClientRect();
    const images = Array.from(s.querySelectorAll('img'));
    return {top: r.top, bottom: r.bottom, width: r.width,
            images: images.length, loaded: images.every(i => i.complete && i.naturalWidth > 0),
            finding: s.querySelector('p.finding').innerText};
  })()
})"""


@pytest.fixture(scope="module")
def report_path(store_path, reproduction_json, tmp_path_factory) -> Path:  # noqa: F811
    out = tmp_path_factory.mktemp("browser")
    return build_report(store_path, out, reproduction=reproduction_json, created=CREATED).path


def inspect_page(path: Path) -> tuple[dict[str, Any], list[str], bytes]:
    """Load ``path`` in headless Chromium at 1280 x 1600.

    Returns
    -------
    found : dict
        The page's image count, broken images, natural widths, inline charts, scripts,
        section headings, scroll height, first section and the summary section's box,
        images and finding sentence (None without one), read after the load event.
    errors : list of str
        :func:`page_errors` of every event received.
    screenshot : bytes
        PNG of the viewport.
    """
    # a short path: the profile holds a unix socket, whose path is limited to 107 bytes
    with tempfile.TemporaryDirectory(prefix="chromium-") as profile:
        browser = DevTools(Path(profile))
        try:
            target = browser.call("Target.createTarget", url="about:blank")["targetId"]
            session = browser.call("Target.attachToTarget", targetId=target,
                                   flatten=True)["sessionId"]
            for domain in ("Page", "Runtime", "Log", "Network"):
                browser.call(f"{domain}.enable", session)
            browser.call("Emulation.setDeviceMetricsOverride", session, width=1280,
                         height=1600, deviceScaleFactor=1, mobile=False)
            browser.call("Page.navigate", session, url=path.as_uri())
            browser.wait_event("Page.loadEventFired")
            found = json.loads(browser.call("Runtime.evaluate", session, expression=_IMAGES,
                                            returnByValue=True)["result"]["value"])
            shot = browser.call("Page.captureScreenshot", session, format="png")["data"]
        finally:
            browser.close()
    return found, page_errors(browser.events), base64.b64decode(shot)


def test_report_renders_in_headless_chromium(report_path):
    source = report_path.read_text()
    expected_images = source.count("<img ")
    expected_charts = source.count('<svg class="chart"')
    # every top-level section of the page source has a heading the browser lays out
    expected_sections = len(re.findall(r"<section[^>]*>\s*<h2", source))
    found, errors, shot = inspect_page(report_path)
    assert errors == []
    assert found["n"] == expected_images >= 5  # SVG figures and the PNG of the grasp
    assert found["charts"] == expected_charts >= 10  # one inline force-trace chart per episode
    assert found["broken"] == 0, found["widths"]
    assert min(found["widths"]) >= 200
    assert found["scripts"] == 0
    assert found["sections"] == expected_sections >= 10
    assert found["height"] > 5000  # a long page, not an error stub
    pixels = matplotlib.image.imread(io.BytesIO(shot), format="png")
    assert pixels.shape[:2] == (1600, 1280)
    assert pixels[..., :3].std() > 0.05  # text and figures, not a blank page


#: The fixture's swept factors as the report names them, and the result field of each.
FACTOR_FIELDS = {"object": "object_name", "mass (kg)": "object_mass_kg",
                 "friction": "object_friction", "controller": "controller",
                 "estimator": "estimator", "mode": "mode"}
OUTCOME_NAMES = ("held", "not lifted", "dropped", "crushed")
Z95 = 1.959963984540054


def outcome_of(result: dict) -> str:
    """The episode's one outcome, from the flags the fixture's rows carry."""
    if result.get("crushed"):
        return "crushed"
    if not result.get("lifted", True):
        return "not lifted"
    return "dropped" if result.get("dropped") else "held"


def percent(k: int, n: int) -> str:
    """``"50 % (31–69 %)"``: the rate with its 95 % Wilson interval, computed here."""
    p = k / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * (p * (1 - p) / n + Z95**2 / (4 * n * n)) ** 0.5 / (1 + Z95**2 / n)
    return (f"{100 * p:.0f} % ({100 * max(0.0, centre - half):.0f}–"
            f"{100 * min(1.0, centre + half):.0f} %)")


def level_text(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def test_first_screen_holds_the_summary_and_its_sentence_matches_the_store(report_path,
                                                                           store_path):  # noqa: F811
    found, errors, _ = inspect_page(report_path)
    assert errors == []
    summary = found["summary"]
    assert found["first"] == "summary"
    # the whole section, sentence, rates and both figures, within the 1280 x 1600 viewport
    assert 0 <= summary["top"] < summary["bottom"] <= 1600, summary
    assert summary["images"] == 2 and summary["loaded"]
    sentence = summary["finding"]

    # recompute the finding from the store's rows
    with ResultStore(store_path, read_only=True) as store:
        results = [r["result"] for r in store.rows(status="ok") if r["kind"] == "episode"]
    outcomes = [outcome_of(r) for r in results]
    effects = {}
    for name, field in FACTOR_FIELDS.items():
        levels = list(dict.fromkeys(r[field] for r in results))
        if all(isinstance(v, float) for v in levels):
            levels.sort()
        table = [[sum(r[field] == lv and o == kind for r, o in zip(results, outcomes,
                                                                     strict=True))
                  for kind in OUTCOME_NAMES] for lv in levels]
        table = [[row[j] for j in range(4) if any(t[j] for t in table)] for row in table]
        chi2, p, _, _ = stats.chi2_contingency(table, correction=False)
        v = (chi2 / (len(results) * (min(len(table), len(table[0])) - 1))) ** 0.5
        first_seen = {v: i for i, v in enumerate(dict.fromkeys(r[field] for r in results))}
        split = tuple(first_seen[r[field]] for r in results)  # the partition of the episodes
        effects[name] = (v, p, levels, split)
    top_v = max(v for v, _, _, _ in effects.values())
    # the store's episodes come from two sessions (a subject with a seed): no test that keeps
    # a session's episodes together can find an effect beyond chance, and the page says so
    sessions = {(r["subject_id"], r["seed"]) for r in results}
    assert len(sessions) == 2
    match = re.match(r"No swept factor changes the outcome beyond chance: none of the (\d+) "
                     r"tested reaches p < 0\.05 after Holm's correction \(permutation tests "
                     r"that keep each of the (\d+) sessions' episodes together\)\. The largest "
                     r"effect is that of (.+?) (?:\(same split as (.+?)\) )?\(Cramér's V "
                     r"([0-9.]+), p [<=] [0-9.e-]+ adjusted\): "
                     r"(held|not lifted|dropped|crushed) in (.+?) of the (\d+) episodes at "
                     r"\3 = (.+?) and in (.+?) of the (\d+) at \3 = (.+?), a difference of "
                     r"(\d+) points \(no interval: 2 sessions are too few to resample\)\.$",
                     sentence)
    assert match, sentence
    tested, n_sessions, name, alias, v_text, outcome, high_rate, high_n, high_level, \
        low_rate, low_n, low_level, difference = match.groups()
    assert int(n_sessions) == 2
    assert int(tested) == len({e[3] for e in effects.values()})  # one test per distinct split
    v, p, levels, split = effects[name]
    assert v == pytest.approx(top_v, abs=1e-12)  # the strongest association of all factors
    assert v_text == f"{top_v:.2f}"
    for other in alias.split(", ") if alias else ():  # factors splitting the episodes alike
        assert effects[other][3] == split
    # the outcome whose rate differs most between the levels, at its highest and lowest level
    counts = {lv: [outcomes[i] for i, r in enumerate(results)
                   if r[FACTOR_FIELDS[name]] == lv] for lv in levels}
    spread = {kind: max(c.count(kind) / len(c) for c in counts.values())
              - min(c.count(kind) / len(c) for c in counts.values()) for kind in OUTCOME_NAMES}
    assert spread[outcome] == max(spread.values())
    by_text = {level_text(lv): c for lv, c in counts.items()}
    high, low = by_text[high_level], by_text[low_level]
    assert high.count(outcome) / len(high) == max(c.count(outcome) / len(c)
                                                  for c in counts.values())
    assert low.count(outcome) / len(low) == min(c.count(outcome) / len(c)
                                                for c in counts.values())
    assert (high_rate, int(high_n)) == (percent(high.count(outcome), len(high)), len(high))
    assert (low_rate, int(low_n)) == (percent(low.count(outcome), len(low)), len(low))
    assert int(difference) == round(100 * (high.count(outcome) / len(high)
                                           - low.count(outcome) / len(low)))


def test_inspection_catches_broken_images_and_errors(tmp_path):
    """Negative control: the same inspection flags what the report must never contain."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html><body><section><h2>x</h2>'
                   '<img src="data:image/png;base64,iVBORw0KGgo=" alt="truncated">'
                   '<img src="missing.png" alt="absent">'
                   '<script>console.error("boom"); undefined_name();</script>'
                   '</section></body></html>')
    found, errors, _ = inspect_page(bad)
    assert found["n"] == 2 and found["broken"] == 2
    assert any("boom" in e for e in errors)
    assert any(e.startswith("exception:") for e in errors)
    assert any(e.startswith("load failed:") or "missing.png" in e for e in errors)
