"""The report renders in headless Chromium with every figure loaded.

Debian's ``chromium`` (``/usr/bin/chromium``) is installed by the test set-up
(``tools/setup_debian.sh``, run by ``make test``). A harness page in ``tmp_path`` loads the
report in an iframe (``--allow-file-access-from-files`` lets it read the frame) and, once the
frame has loaded, writes into its own DOM how many ``<img>`` are complete with a natural width,
which failed, and the figure count the report states; ``--dump-dom`` prints that DOM. A second
run takes a screenshot of the report, which must not be blank. Both for a finished session's
report and for the partial report of an unfinished one. (What each figure draws, its texts
apart and inside its canvas and its legends off the data, is checked from matplotlib's renderer:
``test/report/test_figure_text_inside.py``, ``test/plots/test_figure_layout.py``.)

Chromium is kept off the network: where the user may (root, as in CI) it runs in a network
namespace of its own with no interface (``unshare --net``); in any case with no background
networking, component updates, sync, QUIC, first-run tasks or proxy, and every host name
resolving to nothing. It runs as a subprocess in its own
session with a timeout, killed by its process group id if it overruns.
"""

from __future__ import annotations

import dataclasses
import functools
import html
import json
import os
import re
import shutil
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.offline.subjects import load_subject
from bike_rig.report import write_report
from test.support.simulated import short_session

CHROMIUM = Path("/usr/bin/chromium")
TIMEOUT_S = 90.0
#: Virtual time Chromium lets the page run before dumping the DOM, ms.
VIRTUAL_TIME_MS = 20000
#: Width of the frame the report is laid out in, px (a narrow window; tables must fit it).
FRAME_WIDTH_PX = 800
#: Trials whose fit figures are in the rendered report (a few; the page layout is the same).
TRIALS = 4
#: Measurement keys with trials in the incomplete session (the others are missing).
KEPT = 2

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-default-apps",
    "--disable-extensions",
    "--disable-breakpad",
    "--host-resolver-rules=MAP * ~NOTFOUND",
    "--no-proxy-server",
    "--hide-scrollbars",
    "--mute-audio",
)

HARNESS = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>harness</title></head>
<body>
<pre id="result">pending</pre>
<iframe id="report" src="{src}" width="{width}" height="900"></iframe>
<script>
const frame = document.getElementById("report");
frame.addEventListener("load", () => {{
  const out = document.getElementById("result");
  try {{
    const doc = frame.contentDocument;
    const images = Array.from(doc.images);
    const ok = (img) => img.complete && img.naturalWidth > 0 && img.naturalHeight > 0;
    const main = doc.getElementById("report");
    out.textContent = JSON.stringify({{
      title: doc.title,
      images: images.length,
      loaded: images.filter(ok).length,
      failed: images.filter((img) => !ok(img)).map((img) => img.alt),
      declared: main ? Number(main.dataset.figures) : null,
      figures: doc.querySelectorAll("figure.report-figure img").length,
      tables: doc.querySelectorAll("table").length,
      height: doc.documentElement.scrollHeight,
      scrollWidth: doc.documentElement.scrollWidth,
      clientWidth: doc.documentElement.clientWidth,
      widest: Math.max(...Array.from(doc.querySelectorAll("table")).map((t) => t.getBoundingClientRect().right)),
    }});
  }} catch (err) {{
    out.textContent = JSON.stringify({{error: String(err)}});
  }}
}});
</script>
</body></html>
"""


@functools.cache
def _no_network() -> tuple[str, ...]:
    """``unshare --net --`` where this user may make a network namespace (root: CI), else nothing.

    In its own network namespace Chromium has no network interface at all; elsewhere the flags
    above keep it off the network.
    """
    unshare = shutil.which("unshare")
    if unshare is None:
        return ()
    probe = subprocess.run([unshare, "--net", "--", "true"], capture_output=True, timeout=10)
    return (unshare, "--net", "--") if probe.returncode == 0 else ()


def run_chromium(args: list[str], profile: Path) -> str:
    """Run headless Chromium with ``args``; its stdout. Fails the test on timeout or error."""
    if not CHROMIUM.exists():
        pytest.fail(f"{CHROMIUM} is missing: run tools/setup_debian.sh (make test does)", pytrace=False)
    cmd = [*_no_network(), str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", *args]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True, cwd=profile
    )
    try:
        out, err = proc.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # its own session: the group id is its pid
        proc.communicate()
        pytest.fail(f"chromium did not finish within {TIMEOUT_S:g} s", pytrace=False)
    if proc.returncode != 0:
        pytest.fail(f"chromium exited with {proc.returncode}: {err[-2000:]}", pytrace=False)
    return out


@pytest.fixture(scope="module", params=["full", "partial"])
def report_file(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """A finished session's report, or the partial report of an unfinished one, and which.

    The full one has the model figures, the trial overview and a few fits; the partial one (its
    first keys' trials only) the overview and the fits.
    """
    tmp = tmp_path_factory.mktemp("chromium-report")
    session = short_session()
    if request.param == "partial":
        kept = set(list(dict.fromkeys(t.key for t in session.trials))[:KEPT])
        session = dataclasses.replace(session, trials=tuple(t for t in session.trials if t.key in kept))
    subject = load_subject(write_simulated_bag(tmp / "bag", session), partial=True)
    assert subject.complete == (request.param == "full")
    subject = dataclasses.replace(subject, trials=subject.trials[:TRIALS])
    return request.param, write_report(subject, tmp / "report").path


def test_report_renders_with_every_figure_loaded(report_file: tuple[str, Path], tmp_path: Path) -> None:
    kind, report_file_path = report_file
    harness = tmp_path / "harness.html"
    harness.write_text(
        HARNESS.format(src=html.escape(report_file_path.as_uri()), width=FRAME_WIDTH_PX), encoding="utf-8"
    )
    profile = tmp_path / "profile"
    profile.mkdir()
    dom = run_chromium(
        ["--allow-file-access-from-files", f"--virtual-time-budget={VIRTUAL_TIME_MS}", "--dump-dom", harness.as_uri()],
        profile,
    )
    m = re.search(r'<pre id="result">(.*?)</pre>', dom, re.S)
    assert m is not None, dom[:2000]
    result = json.loads(html.unescape(m.group(1)))
    assert "error" not in result, result
    assert result["title"].endswith("bicycle parameter report")
    assert ("partial" in result["title"]) == (kind == "partial")
    # 9 model figures (none without parameters) + the trial overview + one fit per trial, all decoded
    assert result["declared"] == (9 if kind == "full" else 0) + 1 + TRIALS
    assert result["images"] == result["declared"] == result["figures"]
    assert result["loaded"] == result["declared"]
    assert result["failed"] == []
    assert result["tables"] >= (8 if kind == "full" else 3)
    assert result["height"] > (5000 if kind == "full" else 2000)  # laid out, not collapsed
    # no table wider than a narrow window: the page does not scroll sideways
    assert result["clientWidth"] == FRAME_WIDTH_PX
    assert result["scrollWidth"] <= result["clientWidth"], result
    assert result["widest"] <= result["clientWidth"], result


def test_report_screenshot_is_not_blank(report_file: tuple[str, Path], tmp_path: Path) -> None:
    profile = tmp_path / "profile"
    profile.mkdir()
    shot = tmp_path / "shot.png"
    run_chromium(
        [
            "--window-size=1200,1600",
            f"--virtual-time-budget={VIRTUAL_TIME_MS}",
            f"--screenshot={shot}",
            report_file[1].as_uri(),
        ],
        profile,
    )
    img = np.asarray(imread(shot))
    assert img.shape[0] == 1600 and img.shape[1] == 1200
    grey = img[..., :3].mean(axis=2)
    dark = float((grey < 0.5).mean())
    assert 0.005 < dark < 0.5, dark  # text and tables on a white page
    assert float(grey.std()) > 0.05
