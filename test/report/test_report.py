"""The session report: what the page says, checked number by number against the core.

Reports of a measurement file (Browser's raw readings), a parameter file (the same bicycle's
parameters with σ, no readings) and a simulated session bag (39 trials, one marked flagged
here) are built once per module; the HTML is parsed with ``html.parser`` and every value and σ
is compared with what the core computes, both as the exact ``data-value``/``data-sigma`` and
as the printed, rounded text.
"""

from __future__ import annotations

import base64
import dataclasses
import math
import re
import struct
from dataclasses import dataclass, field
from functools import partial
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import PARAMETER_NAMES
from bike_rig.core.errors import BikeRigError, ModelError
from bike_rig.core.io_yaml import dump_parameters_yaml
from bike_rig.core.period.result import Flag, FlagCode
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.textfmt import TABLE2_ORDER, format_value_sigma, sigma_digits
from bike_rig.core.uncertainty.budget import uncertainty_budget
from bike_rig.core.uncertainty.matrix_sigma import MATRIX_NAMES, canonical_with_sigma
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from bike_rig.core.whipple import stable_speed_range
from bike_rig.offline.subjects import Subject, load_subject
from bike_rig.pipeline.fit_details import FitDetails
from bike_rig.report import REPORT_FILE, Report, ReportOutputError, build_report, write_report
from bike_rig.report.figures import FigureSpec, draw_figures
from test.support.simulated import short_session

BROWSER = config_file("bicycles/browser.yaml")
#: The model figures of every report: side view; eigenvalues and root locus without and with
#: the rider; weave and capsize eigenvectors; Bode without and with the rider.
MODEL_FIGURES = 9
GENERATED = "2026-01-01 00:00:00 UTC"
#: Index of the bag trial marked as flagged, and its flag's reason (with HTML to escape).
FLAGGED = 4
FLAG_REASON = "envelope <modulated> & 'phase' drifts"


# --------------------------------------------------------------------------------------------
# A small reader of the report's HTML
# --------------------------------------------------------------------------------------------


@dataclass
class Cell:
    """One ``<td>``/``<th>``: its text and attributes."""

    text: str = ""
    attrs: dict[str, str] = field(default_factory=dict)


@dataclass
class Page:
    """What the tests look at in a report page."""

    tables: dict[str, list[list[Cell]]] = field(default_factory=dict)
    sections: dict[str, str] = field(default_factory=dict)
    images: list[str] = field(default_factory=list)
    main: dict[str, str] = field(default_factory=dict)
    tags: set[str] = field(default_factory=set)
    links: list[str] = field(default_factory=list)
    flags: list[tuple[str, str]] = field(default_factory=list)
    text: str = ""

    def rows(self, table_id: str) -> dict[str, list[Cell]]:
        """Body rows of a table keyed by the first cell's ``data-key`` (or ``data-trial``)."""
        out = {}
        for row in self.tables[table_id]:
            a = row[0].attrs
            key = a.get("data-key") or a.get("data-trial")
            if key is not None:
                out[key] = row
        return out


class PageParser(HTMLParser):
    """Collects tables (body rows of cells), section texts, images, tags and links."""

    def __init__(self) -> None:
        """An empty page."""
        super().__init__(convert_charrefs=True)
        self.page = Page()
        self._table: str | None = None
        self._row: list[Cell] | None = None
        self._cell: Cell | None = None
        self._in_head = False
        self._section: list[str] = []
        self._flag: str | None = None
        self._flag_text = ""
        self._text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        """Open a table, row, cell, section or flag; record the tag and its links."""
        a = {k: v or "" for k, v in attrs}
        self.page.tags.add(tag)
        for k in ("src", "href"):
            if k in a and tag != "img":
                self.page.links.append(a[k])
        if tag == "table":
            self._table = a.get("id", f"table-{len(self.page.tables)}")
            self.page.tables[self._table] = []
        elif tag == "thead":
            self._in_head = True
        elif tag == "tbody":
            self._in_head = False
        elif tag == "tr" and self._table is not None and not self._in_head:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = Cell(attrs=a)
        elif tag == "img":
            self.page.images.append(a.get("src", ""))
        elif tag == "main":
            self.page.main = a
        elif tag == "section":
            self._section.append(a.get("id", ""))
            self.page.sections[a.get("id", "")] = ""
        elif tag == "li" and "data-code" in a:
            self._flag = a["data-code"]
            self._flag_text = ""

    def handle_endtag(self, tag: str) -> None:
        """Close what ``tag`` opened."""
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._cell.text = self._cell.text.strip()
            self._row.append(self._cell)
            self._cell = None
        elif tag == "tr" and self._row is not None and self._table is not None:
            self.page.tables[self._table].append(self._row)
            self._row = None
        elif tag == "table":
            self._table = None
        elif tag == "section" and self._section:
            self._section.pop()
        elif tag == "li" and self._flag is not None:
            self.page.flags.append((self._flag, self._flag_text))
            self._flag = None

    def handle_data(self, data: str) -> None:
        """Add text to the page, and to the open cell, section and flag."""
        self._text.append(data)
        if self._cell is not None:
            self._cell.text += data
        if self._section:
            self.page.sections[self._section[-1]] += data
        if self._flag is not None:
            self._flag_text += data

    def close(self) -> None:
        """Finish the page's text."""
        super().close()
        self.page.text = "".join(self._text)


def parse(text: str) -> Page:
    """The page of a report's HTML."""
    p = PageParser()
    p.feed(text)
    p.close()
    return p.page


def check_value_sigma(value_cell: Cell, sigma_cell: Cell, value: float, sigma: float) -> None:
    """The cells hold ``value`` and ``sigma`` exactly (data attributes) and as rounded text.

    σ to one or two significant digits by the one rule (:func:`bike_rig.core.textfmt.sigma_digits`),
    the value to the same decimal place.
    """
    assert float(value_cell.attrs["data-value"]) == value
    assert float(value_cell.attrs["data-sigma"]) == sigma
    shown_v = float(value_cell.text.split()[0])
    if sigma > 0:
        shown_s = float(sigma_cell.text)
        decimals = len(sigma_cell.text.split(".")[1]) if "." in sigma_cell.text else 0
        assert shown_s == pytest.approx(sigma, rel=0.051, abs=0.5 * 10.0**-decimals)
        digits = sigma_cell.text.replace(".", "").lstrip("0")
        assert len(digits) == sigma_digits(sigma) or decimals == 0, sigma_cell.text
        value_decimals = len(value_cell.text.split()[0].split(".")[1]) if "." in value_cell.text else 0
        assert value_decimals == decimals
        assert abs(shown_v - value) <= 0.5 * 10.0**-decimals * (1 + 1e-9)
    else:
        assert shown_v == pytest.approx(value, rel=1e-5, abs=1e-12)
        assert sigma_cell.text == "0"


# --------------------------------------------------------------------------------------------
# Reports, built once
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Built:
    """A built report with its parsed page."""

    report: Report
    page: Page

    @property
    def subject(self) -> Subject:
        """The report's bicycle."""
        return self.report.subject


def _build(subject: Subject) -> Built:
    report = build_report(subject, GENERATED)
    return Built(report, parse(report.html))


@pytest.fixture(scope="module")
def measurement_report() -> Built:
    """Browser from its raw readings (periods given as numbers: no trials)."""
    return _build(load_subject(BROWSER))


@pytest.fixture(scope="module")
def parameter_report(tmp_path_factory: pytest.TempPathFactory) -> Built:
    """Browser's parameters with σ written as a parameter file: no readings, no trials."""
    path = tmp_path_factory.mktemp("params") / "browser-params.yaml"
    path.write_text(dump_parameters_yaml(load_subject(BROWSER).parameters), encoding="utf-8")
    return _build(load_subject(path))


def _flagged(subject: Subject) -> Subject:
    """The bag subject with one trial marked flagged and left out, and a name to escape."""
    trials = list(subject.trials)
    t = trials[FLAGGED]
    fit = dataclasses.replace(t.fit, flags=(Flag(FlagCode.BEATING, FLAG_REASON),))
    result = dataclasses.replace(t.result, fit=fit)
    trials[FLAGGED] = dataclasses.replace(t, result=result, used=False, note="left out: <flagged>")
    return dataclasses.replace(subject, name="Browser <b>& Co</b>", trials=tuple(trials))


@pytest.fixture(scope="module")
def bag_report(tmp_path_factory: pytest.TempPathFactory) -> Built:
    """A simulated session bag of the Browser (39 trials), one trial marked flagged."""
    bag = write_simulated_bag(tmp_path_factory.mktemp("bag") / "session", short_session())
    return _build(_flagged(load_subject(bag)))


# --------------------------------------------------------------------------------------------
# Numbers
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("which", ["measurement_report", "parameter_report", "bag_report"])
def test_parameters_with_sigma_as_computed_without_and_with_rider(which: str, request: pytest.FixtureRequest) -> None:
    built: Built = request.getfixturevalue(which)
    ps = built.subject.parameters
    rider = add_rider(ps, PAPER_RIDER).parameters
    rows = built.page.rows("table-parameters")
    assert list(rows) == list(TABLE2_ORDER)
    assert set(rows) == set(PARAMETER_NAMES)  # the 25 parameters and g
    for key, row in rows.items():
        check_value_sigma(row[2], row[3], ps.parameters.value(key), ps.parameters.sigma(key))
        check_value_sigma(row[4], row[5], rider.value(key), rider.sigma(key))
    # the rider changes the rear frame only
    changed = {k for k in PARAMETER_NAMES if rider.value(k) != ps.parameters.value(k)}
    assert changed == {"mB", "xB", "zB", "IBxx", "IBxz", "IByy", "IBzz"}


@pytest.mark.parametrize("which", ["measurement_report", "parameter_report", "bag_report"])
def test_matrices_and_speeds_as_computed(which: str, request: pytest.FixtureRequest) -> None:
    built: Built = request.getfixturevalue(which)
    ps = built.subject.parameters
    variants = (ps, add_rider(ps, PAPER_RIDER))
    matrices = built.page.rows("table-matrices")
    assert len(matrices) == 16
    speeds = built.page.rows("table-speeds")
    for col, p in enumerate(variants):
        ms = canonical_with_sigma(p)
        for name in MATRIX_NAMES:
            sep = "" if name == "M" else "_"
            for i in range(2):
                for j in range(2):
                    row = matrices[f"{name}{sep}{i + 1}{j + 1}"]
                    val = float(getattr(ms.matrices, name)[i, j])
                    sig = float(getattr(ms.sigma, name)[i, j])
                    check_value_sigma(row[1 + 2 * col], row[2 + 2 * col], val, sig)
        cs = critical_speeds_with_sigma(p)
        for attr in ("weave", "capsize"):
            sp = getattr(cs, attr)
            assert sp is not None
            check_value_sigma(speeds[attr][1 + 2 * col], speeds[attr][2 + 2 * col], sp.speed, sp.sigma)
        lo, hi = stable_speed_range(ms.matrices, ms.g)[0]
        assert f"{lo:.3f} to {hi:.3f} m/s" in speeds["stable"][1 + col].text
        assert cs.weave is not None and cs.capsize is not None
        assert lo == pytest.approx(cs.weave.speed) and hi == pytest.approx(cs.capsize.speed)


def test_monte_carlo_check_agrees_with_linear_sigma(measurement_report: Built) -> None:
    rows = measurement_report.page.tables["table-monte-carlo"]
    assert len(rows) == 4  # weave and capsize, without and with the rider
    for row in rows:
        linear, mc, ratio = (float(row[k].attrs["data-value"]) for k in (2, 3, 5))
        assert mc / linear == pytest.approx(ratio)
        assert ratio == pytest.approx(1.0, abs=0.15)


@pytest.mark.parametrize("which", ["measurement_report", "parameter_report", "bag_report"])
def test_budget_as_computed(which: str, request: pytest.FixtureRequest) -> None:
    built: Built = request.getfixturevalue(which)
    ps = built.subject.parameters
    for table_id, p, outputs in (
        ("table-budget", ps, None),
        ("table-budget-rider", add_rider(ps, PAPER_RIDER), ("weave speed", "capsize speed")),
    ):
        budget = uncertainty_budget(p)
        rows = built.page.rows(table_id)
        expected = [o for o in budget.outputs if outputs is None or o.output in outputs]
        assert set(rows) == {o.output for o in expected}
        if outputs is None:
            assert len(rows) == 27  # 25 parameters, weave and capsize speeds
        for o in expected:
            row = rows[o.output]
            check_value_sigma(row[2], row[3], o.value, o.sigma)
            shown = re.findall(r"(\S+) (\d+\.\d) %", row[4].text)
            assert [s for s, _ in shown] == [s.input for s in o.shares[:3]]
            for (_, pct), s in zip(shown, o.shares):
                assert float(pct) == pytest.approx(100 * s.share, abs=0.051)
    text = built.page.sections["budget"]
    if built.subject.kind == "parameters":
        assert "no budget over readings" in text
    else:
        assert f"{len(budget.inputs)} raw readings" in text
        assert built.page.tables["table-ranking"]


# --------------------------------------------------------------------------------------------
# Sections for each kind of input
# --------------------------------------------------------------------------------------------


def test_measurement_file_report(measurement_report: Built) -> None:
    page, subject = measurement_report.page, measurement_report.subject
    assert subject.kind == "measurements" and not subject.trials
    assert "gives its periods as numbers" in page.sections["trials"]
    assert "Not a recorded session" in page.sections["timeline"]
    readings = page.rows("table-readings")
    assert subject.measurements is not None
    assert set(readings) == set(subject.measurements.readings)
    assert len(page.tables["table-com"]) == 4  # both mass-centre methods, frame and fork
    assert str(BROWSER) in page.text


def test_parameter_file_report_says_what_it_lacks(parameter_report: Built) -> None:
    page = parameter_report.page
    assert parameter_report.subject.kind == "parameters"
    assert "A parameter file holds no trials" in page.sections["trials"]
    assert "A parameter file holds no raw readings" in page.sections["readings"]
    assert "Not a recorded session" in page.sections["timeline"]
    assert "table-trials" not in page.tables
    assert page.tables["table-monte-carlo"]  # drawn from the parameters' covariance


def test_bag_report_every_trial_with_fit_and_flags(bag_report: Built) -> None:
    page, subject = bag_report.page, bag_report.subject
    assert len(subject.trials) == 39
    rows = page.rows("table-trials")
    assert list(rows) == [t.trial_id for t in subject.trials]
    for t in subject.trials:
        row = rows[t.trial_id]
        assert row[1].text == t.key
        check_value_sigma(row[2], row[3], t.fit.period, t.fit.period_sigma)
        assert float(row[4].attrs["data-value"]) == t.fit.r2
        assert float(row[5].attrs["data-value"]) == t.fit.zeta
        assert float(row[6].attrs["data-value"]) == t.fit.n_cycles
        assert row[7].text == ("yes" if t.used else "no")
        assert float(row[10].attrs["data-value"]) == t.start_s
        assert float(row[11].attrs["data-value"]) == t.stop_s
        assert row[12].text == (FitDetails.of(t.result).summary(t.fit.period) if t.fit.valid else "")
    flagged = subject.trials[FLAGGED]
    assert page.flags == [("beating", f"beating: {FLAG_REASON}")]
    assert rows[flagged.trial_id][9].text == "left out: <flagged>"
    assert "(39 trials, 38 used, 1 flagged)" in page.text
    combined = page.rows("table-periods")
    assert subject.measurements is not None
    for key, row in combined.items():
        r = subject.measurements.readings[key]
        check_value_sigma(row[3], row[4], r.value, r.sigma)


def test_bag_report_timeline(bag_report: Built) -> None:
    page, subject = bag_report.page, bag_report.subject
    assert subject.duration_s is not None and subject.timeline
    assert f"lasted {subject.duration_s:.1f} s" in page.sections["timeline"]
    rows = page.tables["table-timeline"]

    def seconds(cell: Cell) -> float | None:
        return None if cell.attrs["data-value"] == "none" else float(cell.attrs["data-value"])

    assert [(seconds(r[0]), r[1].text) for r in rows] == [(e.time_s, e.what) for e in subject.timeline]


def test_text_is_escaped(bag_report: Built) -> None:
    html = bag_report.report.html
    assert "<b>& Co</b>" not in html and "&lt;b&gt;&amp; Co&lt;/b&gt;" in html
    assert "<modulated>" not in html and "&lt;modulated&gt; &amp; &#x27;phase&#x27;" in html
    assert "Browser <b>& Co</b>: bicycle parameter report" in bag_report.page.text


# --------------------------------------------------------------------------------------------
# Figures and self-containment
# --------------------------------------------------------------------------------------------


def _png_size(uri: str) -> tuple[int, int]:
    assert uri.startswith("data:image/png;base64,")
    data = base64.b64decode(uri.split(",", 1)[1])
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    w, h = struct.unpack(">II", data[16:24])
    return int(w), int(h)


@pytest.mark.parametrize(
    ("which", "trial_figures"), [("measurement_report", 0), ("parameter_report", 0), ("bag_report", 1 + 39)]
)
def test_every_figure_embedded(which: str, trial_figures: int, request: pytest.FixtureRequest) -> None:
    built: Built = request.getfixturevalue(which)
    assert [f.unavailable for f in built.report.figures if f.uri is None] == []
    n = MODEL_FIGURES + trial_figures
    assert built.report.drawn == n == len(built.page.images) == int(built.page.main["data-figures"])
    for uri in built.page.images:
        w, h = _png_size(uri)
        assert 200 < w < 1200 and 150 < h < 1000
    assert f"figures{n}" in built.page.text.replace("\n", "")  # the header states the count


@pytest.mark.parametrize("which", ["measurement_report", "bag_report"])
def test_page_is_self_contained(which: str, request: pytest.FixtureRequest) -> None:
    built: Built = request.getfixturevalue(which)
    page = built.page
    assert not page.tags & {"script", "link", "iframe", "object", "embed"}
    assert all(link.startswith("#") for link in page.links)
    assert all(src.startswith("data:image/png;base64,") for src in page.images)
    assert "url(" not in built.report.html and "@import" not in built.report.html


def test_write_report(tmp_path: Path, measurement_report: Built) -> None:
    out = tmp_path / "a" / "report"
    written = write_report(measurement_report.subject, out, GENERATED, workers=1)
    assert written.path == out / REPORT_FILE
    text = written.path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    # the same page drawn in this process as in the fixture's worker processes
    assert text == measurement_report.report.html
    (tmp_path / "file").write_text("x")
    with pytest.raises(ReportOutputError, match="exists and is not a directory"):
        write_report(measurement_report.subject, tmp_path / "file")


# --------------------------------------------------------------------------------------------
# Pieces
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "sigma", "expected"),
    [
        (0.341234, 0.00123, ("0.3412", "0.0012")),
        (1.0, 0.0996, ("1.00", "0.10")),  # σ rounds up to the next decade
        (9.81, 0.01, ("9.810", "0.010")),
        (-0.0720, 0.00079, ("-0.07200", "0.00079")),
        (1234.5, 56.0, ("1234", "56")),
        (12345.0, 567.0, ("12340", "570")),
        (0.3141592653589793, 0.0, ("0.314159", "0")),
        (2.5, math.nan, ("2.5", "–")),
    ],
)
def test_format_value_sigma(value: float, sigma: float, expected: tuple[str, str]) -> None:
    assert format_value_sigma(value, sigma, digits=2) == expected


@pytest.mark.parametrize(
    ("value", "sigma", "expected"),
    [
        (0.341234, 0.00123, ("0.341", "0.001")),  # the paper's tables: σ to one digit
        (1.0, 0.0996, ("1.0", "0.1")),
        (102.78, 0.46, ("102.8", "0.5")),
        (1234.5, 56.0, ("1230", "60")),
    ],
)
def test_format_value_sigma_paper_style(value: float, sigma: float, expected: tuple[str, str]) -> None:
    assert format_value_sigma(value, sigma) == expected


def _tiny_figure(k: int) -> Figure:
    fig = Figure(figsize=(3.0, 2.0))
    fig.add_subplot().plot(np.arange(5), np.arange(5) * k)
    return fig


def _missing_module() -> Figure:
    raise ModuleNotFoundError("No module named 'bike_rig.plots.nothing'", name="bike_rig.plots.nothing")


def _no_such_mode() -> Figure:
    raise ModelError("no such mode")


def _bug() -> Figure:
    raise ZeroDivisionError("a bug")


def test_draw_figures_reports_unavailable_and_raises_bugs() -> None:
    specs = [FigureSpec(f"t{k}", f"tiny {k}", "", partial(_tiny_figure, k)) for k in range(4)]
    specs += [FigureSpec("missing", "m", "", _missing_module), FigureSpec("mode", "n", "", _no_such_mode)]
    serial = draw_figures(specs, workers=1)
    parallel = draw_figures(specs, workers=2)
    assert [f.uri for f in serial] == [f.uri for f in parallel]
    assert [f.uri is not None for f in serial] == [True] * 4 + [False, False]
    assert serial[4].unavailable == "not available: bike_rig.plots.nothing is not installed"
    assert serial[5].unavailable == "cannot be drawn: no such mode"
    for workers in (1, 2):
        with pytest.raises(ZeroDivisionError):
            draw_figures([*specs[:4], FigureSpec("bug", "b", "", _bug)], workers=workers)
    assert issubclass(ReportOutputError, BikeRigError)
