"""The report's sections as HTML.

The bicycle and its source, the parameters (paper Table 2), the canonical matrices (Table 3),
the critical speeds, the uncertainty budget, the trials and the timeline. A section without
data says why instead of being empty.

Each function takes the :class:`~bike_rig.offline.subjects.Subject` and/or the computed
:class:`~bike_rig.report.results.ReportResults` and returns a :class:`~.html.Raw` section.
Units: SI throughout (lam in rad, speeds in m/s, periods in s, times in s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .. import __version__
from ..core.feedback import GAIN_KEYS, GAIN_UNITS
from ..core.period import FlagCode
from ..core.textfmt import LABELS, TABLE2_ORDER
from ..core.uncertainty.budget import CAPSIZE, PARAMETERS, WEAVE, OutputBudget, UncertaintyBudget, input_ranking
from ..core.uncertainty.matrix_sigma import MATRIX_NAMES
from ..core.uncertainty.speed_sigma import SpeedWithSigma
from ..offline.subjects import SessionTrial, Subject
from ..offline.timeline import TIME_BASE
from ..pipeline.fit_details import FitDetails
from .figures import ReportFigure
from .html import Raw, esc, number_cell, section, table, value_sigma_cells
from .results import ReportResults, Variant

__all__ = [
    "KIND_TEXT",
    "budget_section",
    "figures_section",
    "header_section",
    "matrices_section",
    "missing_text",
    "omitted_section",
    "parameters_section",
    "readings_section",
    "speeds_section",
    "timeline_section",
    "trials_section",
]

#: How each input kind is named on the page.
KIND_TEXT = {
    "measurements": "measurement file (raw readings)",
    "parameters": "parameter file (the 25 parameters with σ, no raw readings)",
    "bag": "session bag (recorded rig session, replayed offline)",
}

#: How many inputs each budget row names.
TOP_SHARES = 3
#: How many inputs the "measure better" ranking lists.
TOP_RANKED = 8


def _p(text: str, css_class: str = "") -> str:
    cls = f' class="{css_class}"' if css_class else ""
    return f"<p{cls}>{esc(text)}</p>"


def _facts(rows: Sequence[tuple[str, str]]) -> str:
    return '<dl class="facts">' + "".join(f"<dt>{esc(k)}</dt><dd>{esc(v)}</dd>" for k, v in rows) + "</dl>"


def _trial_counts(subject: Subject) -> str:
    """``N trials, U used, F flagged, A aborted``: every trial of the session, aborted ones too.

    N counts the trials a bag announced without samples to fit (aborted at once) as well.
    """
    n = len(subject.trials) + len(subject.not_replayed)
    used = sum(t.used for t in subject.trials)
    flagged = sum(bool(t.result.flags) for t in subject.trials)  # (the trial's flags too: aborted, gap…)
    aborted = sum(state == "aborted" for _, state in subject.not_replayed)
    for t in subject.trials:
        aborted += any(f.code is FlagCode.ABORTED for f in (*t.result.trial_flags, *t.fit.flags))
    other = len(subject.not_replayed) - sum(state == "aborted" for _, state in subject.not_replayed)
    text = f"{n} trials, {used} used, {flagged} flagged"
    return text + (f", {aborted} aborted" if aborted else "") + (f", {other} without samples" if other else "")


def missing_text(subject: Subject) -> str:
    """What an incomplete session still lacks: its measurement keys without a usable trial."""
    keys = ", ".join(subject.missing) or "unknown"
    return f"a usable trial for {keys}"


def header_section(subject: Subject, results: ReportResults | None, figures: int, generated: str) -> Raw:
    """Title, what the bicycle is and where its data came from, the contents.

    ``results`` is None for an incomplete session: the header says the report is partial and
    what is missing, and the contents list the sections it has.
    """
    ps = subject.parameter_set
    facts = [
        ("bicycle", subject.name),
        ("input", subject.path),
        ("kind", KIND_TEXT.get(subject.kind, subject.kind)),
    ]
    if ps is None:
        facts.append(("partial report", "the session is incomplete; no parameters, model or budget"))
        facts.append(("missing", missing_text(subject)))
    else:
        facts.append(("parameters from", ps.source))
    if ps is not None and ps.com:
        facts.append(("mass centres", ", ".join(f"{k}: {e.used.value}" for k, e in ps.com.items())))
    if subject.trials or subject.not_replayed:
        facts.append(("trials", _trial_counts(subject)))
    if subject.duration_s is not None:
        facts.append(("session length", f"{subject.duration_s:.1f} s"))
    rider = results.rider.rider if results is not None else None
    if rider is not None:
        facts.append(
            (
                "rider variant",
                f"{rider.name}: {rider.mass:g} kg at x = {rider.x:g} m, z = {rider.z:g} m, lumped into the rear frame",
            )
        )
    facts += [("figures", str(figures)), ("generated", f"{generated} by bike_rig {__version__}")]
    toc = [
        ("parameters", "Benchmark parameters (Table 2)"),
        *([("model", "Model (not computed)")] if results is None else []),
        *([("matrices", "Canonical matrices (Table 3)")] if results is not None else []),
        *([("speeds", "Critical speeds and stable range")] if results is not None else []),
        *(
            [("closed-loop", "Closed loop (feedback)")]
            if results is not None and results.closed_loop is not None
            else []
        ),
        ("budget", "Uncertainty budget"),
        ("trials", "Trials"),
        ("timeline", "Timeline"),
        ("readings", "Raw readings"),
        ("figures", "Figures"),
    ]
    nav = "<nav><ul>" + "".join(f'<li><a href="#{k}">{esc(t)}</a></li>' for k, t in toc) + "</ul></nav>"
    title = "partial bicycle parameter report" if ps is None else "bicycle parameter report"
    body = [f"<h1>{esc(subject.name)}: {title}</h1>", _facts(facts)]
    if ps is None:
        body.append(
            _p(
                f"Partial report of an incomplete session: missing {missing_text(subject)}. The trials, their "
                "figures, the timeline and the readings are shown; the sections that need the parameters say so.",
                "note partial",
            )
        )
    body += [_p(n, "note") for n in subject.notes]
    body.append(nav)
    return Raw('<header id="top">\n' + "\n".join(body) + "\n</header>")


def omitted_section(subject: Subject, section_id: str, title: str, what: str) -> Raw:
    """A section an incomplete session cannot have: one line saying so and what is missing."""
    text = f"Not computed ({what}): they need the parameters, and the session still lacks {missing_text(subject)}."
    return section(section_id, title, [_p(text, "note omitted")])


def parameters_section(results: ReportResults) -> Raw:
    """The 25 parameters and g with σ, as the paper's Table 2, and with the rider (Table 4)."""
    bare, rider = results.bare.parameters.parameters, results.rider.parameters.parameters
    rows = []
    for key in TABLE2_ORDER:
        label, unit = LABELS[key]
        rows.append(
            [
                Raw(f'<td data-key="{esc(key)}">{esc(label)}</td>'),
                unit,
                value_sigma_cells(bare.value(key), bare.sigma(key)),
                value_sigma_cells(rider.value(key), rider.sigma(key)),
            ]
        )
    head = ["parameter", "unit", "value", "σ", f"value {results.rider.label}", "σ"]
    body = [
        table(head, rows, "params", "table-parameters", "Benchmark parameters (paper Table 2 layout)"),
        _p(
            "σ to two significant digits, the value to the same decimal place; correlations between the "
            "parameters are kept in every σ derived from them. The rider only changes the rear frame "
            "(m_B, x_B, z_B, I_B**), as in the paper's Table 4.",
            "note",
        ),
    ]
    com = results.bare.parameters.com
    if com:
        names = {"B": "rear frame", "H": "fork and handlebar"}
        crow = []
        for part, est in com.items():
            for method, c in (("centroid (Eq 17-19)", est.centroid), ("least squares (Eq 20)", est.least_squares)):
                crow.append(
                    [
                        names.get(part, part),
                        method,
                        value_sigma_cells(float(c.values[0]), float(c.sigmas[0])),
                        value_sigma_cells(float(c.values[1]), float(c.sigmas[1])),
                        est.more_accurate.value,
                        est.used.value,
                    ]
                )
        head = ["part", "method", "x [m]", "σ", "z [m]", "σ", "more accurate", "used"]
        body.append(table(head, crow, "com", "table-com", "Mass centres by both methods"))
    return section("parameters", "Benchmark parameters", body)


def _coefficient_rows(variants: Sequence[Variant]) -> list[list[str]]:
    rows: list[list[str]] = []
    for name in MATRIX_NAMES:
        for i in range(2):
            for j in range(2):
                sep = "" if name == "M" else "_"
                cells: list[str] = [Raw(f'<td data-key="{name}{sep}{i + 1}{j + 1}">{esc(name)}{i + 1}{j + 1}</td>')]
                for v in variants:
                    val = float(getattr(v.matrices.matrices, name)[i, j])
                    sig = float(getattr(v.matrices.sigma, name)[i, j])
                    cells.append(value_sigma_cells(val, sig))
                rows.append(cells)
    return rows


def matrices_section(results: ReportResults) -> Raw:
    """M, C1, K0, K2 with σ, as the paper's Table 3, without and with the rider (Table 5)."""
    head = ["coefficient", "value without rider", "σ", f"value {results.rider.label}", "σ"]
    body = [
        table(
            head,
            _coefficient_rows(results.variants),
            "matrices",
            "table-matrices",
            "Canonical matrices M, C1, K0, K2 (paper Table 3 layout)",
        ),
        _p(
            "Indices: 1 = roll φ, 2 = steer δ; M q̈ + v C1 q̇ + (g K0 + v² K2) q = f. σ from the full parameter "
            "covariance (the paper's Table 3 treats the parameters as independent).",
            "note",
        ),
    ]
    return section("matrices", "Canonical matrices", body)


def _speed_cells(sp: SpeedWithSigma | None) -> Raw:
    if sp is None:
        return value_sigma_cells(None, None)
    return value_sigma_cells(sp.speed, sp.sigma)


def _range_text(stable: tuple[tuple[float, float], ...]) -> str:
    if not stable:
        return "never stable"
    parts = [f"{lo:.3f} to {'∞' if math.isinf(hi) else f'{hi:.3f}'}" for lo, hi in stable]
    return ", ".join(parts) + " m/s"


def _monte_carlo_table(results: ReportResults) -> list[str]:
    if not results.monte_carlo:
        return []
    rows: list[list[str]] = []
    for v, mc in zip(results.variants, results.monte_carlo):
        for d in (mc.weave, mc.capsize):
            rows.append(
                [
                    Raw(f'<td data-key="{esc(d.name)}">{esc(d.name)}</td>'),
                    v.label,
                    number_cell(d.linear_sigma, ".3g"),
                    number_cell(d.std, ".3g"),
                    number_cell(d.robust_std, ".3g"),
                    number_cell(d.ratio, ".3f"),
                    number_cell(d.mean, ".4f"),
                    str(d.missing),
                ]
            )
    mc = results.monte_carlo[0]
    head = ["speed", "variant", "linear σ [m/s]", "Monte Carlo σ", "robust σ", "ratio", "mean [m/s]", "draws without"]
    return [
        table(head, rows, "monte-carlo", "table-monte-carlo", "Monte Carlo check of the speeds' σ"),
        _p(
            f"{mc.samples} normal draws of the {mc.input_kind} (seed {mc.seed}), each carried through the whole "
            "chain; the ratio is the Monte Carlo σ over the linear σ (1 when the first-order σ is right). "
            "Robust σ: half the 15.9 to 84.1 % percentile range." + _rider_draws_note(results),
            "note",
        ),
    ]


def _rider_draws_note(results: ReportResults) -> str:
    """What the Monte Carlo does with a rider that has σ of its own (a Yeadon rider), or ""."""
    rider = results.rider.rider
    if rider is None or rider.sensitivity is None:
        return ""
    return (
        f" {rider.name}'s own inputs (body measurements) are drawn too, and the rider moves with the drawn "
        "bicycle parameters of its pose, both through its first-order Jacobian."
    )


def speeds_section(results: ReportResults) -> Raw:
    """Weave and capsize speeds with σ and the stable speed range.

    Without and with the rider, and the Monte Carlo check of their σ.
    """
    rows: list[list[str]] = []
    for name, attr in (("weave speed", "weave"), ("capsize speed", "capsize")):
        row: list[str] = [Raw(f'<td data-key="{attr}">{esc(name)}</td>')]
        for v in results.variants:
            row.append(_speed_cells(getattr(v.speeds, attr)))
        rows.append(row)
    stable: list[str] = [Raw('<td data-key="stable">stable speed range</td>')]
    stable += [Raw(f'<td colspan="2">{esc(_range_text(v.stable))}</td>') for v in results.variants]
    rows.append(stable)
    head = ["", "without rider [m/s]", "σ", f"{results.rider.label} [m/s]", "σ"]
    body = [
        table(head, rows, "speeds", "table-speeds", "Critical speeds"),
        _p(
            "Weave speed: where the weave pair becomes stable; capsize speed: where the capsize root becomes "
            "unstable. σ to first order from the parameter covariance (implicit function theorem).",
            "note",
        ),
        *_monte_carlo_table(results),
    ]
    return section("speeds", "Critical speeds", body)


def closed_loop_section(results: ReportResults) -> Raw:
    """The closed loop of the steer-torque feedback: its gains, speeds with σ and stable ranges.

    Raises:
        ValueError: The results have no closed loop.
    """
    cl = results.closed_loop
    if cl is None:
        raise ValueError("no closed loop in these results")
    fb = cl.feedback
    gains = [
        [Raw(f'<td data-key="{k}">{k}</td>'), u, s.describe()]
        for k, u, s in zip(GAIN_KEYS, GAIN_UNITS, fb.schedules, strict=True)
    ]
    rows: list[list[str]] = []
    for name, attr in (("weave speed", "weave"), ("capsize speed", "capsize")):
        row: list[str] = [Raw(f'<td data-key="{attr}">{esc(name)}</td>')]
        row += [_speed_cells(getattr(cs, attr)) for cs in cl.speeds]
        rows.append(row)
    stable: list[str] = [Raw('<td data-key="stable">stable speed range</td>')]
    stable += [Raw(f'<td colspan="2">{esc(_range_text(r))}</td>') for r in cl.stable]
    rows.append(stable)
    head = ["", "without rider [m/s]", "σ", f"{results.rider.label} [m/s]", "σ"]
    body = [
        _p(
            f"Steer-torque state feedback '{fb.name}' ({fb.source or 'built in'}): "
            "T_δ = −(kφ φ + kδ δ + kφ̇ φ̇ + kδ̇ δ̇) added to the steer torque; the closed loop is A − B K."
        ),
        table(["gain", "unit", "value"], gains, "gains", "table-gains", "Feedback gains"),
        table(head, rows, "speeds", "table-closed-loop", "Critical speeds of the closed loop"),
        _p(
            "Weave speed: the lowest speed where an oscillatory pair becomes stable; capsize speed: the lowest "
            "where a real root becomes unstable (of the closed loop). σ to first order from the parameter "
            "covariance and the gains given with σ (independent; the others exact).",
            "note",
        ),
    ]
    return section("closed-loop", "Closed loop (feedback)", body)


def _share_list(o: OutputBudget) -> Raw:
    if not o.shares:
        why = "no σ (exact input)" if o.sigma == 0 else "σ undefined (double root)"
        return Raw(f'<td class="note">{esc(why)}</td>')
    spans = [
        f'<span class="share" data-input="{esc(s.input)}" data-share="{s.share!r}">'
        f"{esc(s.input)} {100 * s.share:.1f} %</span>"
        for s in o.shares[:TOP_SHARES]
    ]
    more = f" (+{len(o.shares) - TOP_SHARES} more)" if len(o.shares) > TOP_SHARES else ""
    return Raw("<td>" + ", ".join(spans) + esc(more) + "</td>")


def _budget_rows(b: UncertaintyBudget) -> list[list[str]]:
    rows: list[list[str]] = []
    order = {k: i for i, k in enumerate(TABLE2_ORDER)}
    for o in sorted(b.outputs, key=lambda o: order.get(o.output, len(order))):
        label = LABELS[o.output][0] if o.output in LABELS else o.output
        rows.append(
            [
                Raw(f'<td data-key="{esc(o.output)}">{esc(label)}</td>'),
                o.unit,
                value_sigma_cells(o.value, o.sigma),
                _share_list(o),
            ]
        )
    return rows


def budget_section(results: ReportResults) -> Raw:
    """Each output's variance split over the inputs; the inputs worth measuring better."""
    b = results.budget
    body: list[str] = []
    if b.input_kind == PARAMETERS:
        body.append(
            _p(
                "This input is a parameter file: it holds no raw readings, so there is no budget over "
                "readings. Each parameter's σ is its own; the speeds' variance is split over the parameters.",
                "note",
            )
        )
    else:
        body.append(_p(f"Inputs: {len(b.inputs)} raw readings (every static reading and every period), independent."))
    head = ["output", "unit", "value", "σ", f"largest shares of the variance (top {TOP_SHARES})"]
    body.append(table(head, _budget_rows(b), "budget", "table-budget", f"Uncertainty budget of {b.bicycle}"))
    speeds = [o.output for o in b.outputs if o.output in (WEAVE, CAPSIZE) and o.shares]
    ranked = input_ranking(b, speeds) if speeds else ()
    if ranked:
        rows = [[r.input, number_cell(100 * r.mean_share, ".1f", "%"), ", ".join(r.leads)] for r in ranked[:TOP_RANKED]]
        body.append(
            table(
                ["input", "mean share", "largest input of"],
                rows,
                "ranking",
                "table-ranking",
                "What to measure better for the critical speeds (mean share over " + " and ".join(speeds) + ")",
            )
        )
    elif all(not o.shares for o in b.outputs):
        body.append(_p("The input carries no σ, so no output has an uncertainty to split.", "note"))
    rb = [o for o in results.rider_budget.outputs if o.output in (WEAVE, CAPSIZE)]
    if rb:
        rows = [
            [
                Raw(f'<td data-key="{esc(o.output)}">{esc(o.output)}</td>'),
                o.unit,
                value_sigma_cells(o.value, o.sigma),
                _share_list(o),
            ]
            for o in rb
        ]
        body.append(
            table(
                head,
                rows,
                "budget",
                "table-budget-rider",
                f"Critical speeds {results.rider.label}: uncertainty budget",
            )
        )
    return section("budget", "Uncertainty budget", body)


def _flags_cell(t: SessionTrial) -> Raw:
    if not t.fit.flags:
        return Raw('<td class="flags"></td>')
    items = "".join(
        f'<li class="flag" data-code="{esc(f.code.value)}">{esc(f.code.value)}: {esc(f.reason)}</li>'
        for f in t.fit.flags
    )
    return Raw(f'<td class="flags"><ul>{items}</ul></td>')


def _time_cell(t: float | None) -> Raw:
    return number_cell(t, ".1f") if t is not None else Raw("<td></td>")


def _trial_rows(trials: Sequence[SessionTrial]) -> list[list[str]]:
    rows: list[list[str]] = []
    for t in trials:
        f = t.fit
        row: list[str] = [
            Raw(f'<td class="trial-id" data-trial="{esc(t.trial_id)}">{esc(t.trial_id)}</td>'),
            t.key,
            value_sigma_cells(f.period, f.period_sigma),
            number_cell(f.r2, ".5f"),
            number_cell(f.zeta, ".2e"),
            number_cell(f.n_cycles, ".1f"),
            "yes" if t.used else "no",
            _flags_cell(t),
            t.note,
            _time_cell(t.start_s),
            _time_cell(t.stop_s),
            FitDetails.of(t.result).summary(f.period) if f.valid else "",
        ]
        rows.append(row)
    return rows


def trials_section(subject: Subject) -> Raw:
    """Every trial with its fit quality and flags, and each period's combined value."""
    if not subject.trials:
        why = {
            "parameters": "A parameter file holds no trials: its parameters were computed elsewhere.",
            "measurements": "This measurement file gives its periods as numbers, not as trial files, so there "
            "are no trials to show.",
        }.get(subject.kind, "This input holds no trials.")
        return section("trials", "Trials", [_p(why, "note")])
    head = [
        "trial",
        "key",
        "period [s]",
        "σ",
        "r²",
        "ζ",
        "cycles",
        "used",
        "flags",
        "note",
        "start [s]",
        "stop [s]",
        "beyond Eq 23",
    ]
    rows = _trial_rows(subject.trials)
    classes = ["bad" if t.fit.flags else "" if t.used else "unused" for t in subject.trials]
    html_table = table(head, rows, "trials", "table-trials", f"Every trial ({_trial_counts(subject)})", classes)
    body = [
        html_table,
        _p(
            "A flagged trial keeps its period but is left out of its period's combination and should be redone; "
            "r² and the cycle count describe the fit window; ζ is the damping ratio. Start and stop are on the "
            f"timeline's clock ({TIME_BASE}). The last column says what the fit found beyond Eq 23: a damping "
            "model other than viscous, the small-swing period of a swing-dependent period, a period that moves "
            "along the record.",
            "note",
        ),
    ]
    m = subject.measurements
    keys = list(dict.fromkeys(t.key for t in subject.trials))
    if m is not None:
        krows: list[list[str]] = []
        for k in keys:
            of_key = [t for t in subject.trials if t.key == k]
            r = m.readings.get(k)
            krows.append(
                [
                    Raw(f'<td data-key="{esc(k)}">{esc(k)}</td>'),
                    str(len(of_key)),
                    str(sum(t.used for t in of_key)),
                    value_sigma_cells(r.value, r.sigma) if r is not None else value_sigma_cells(None, None),
                ]
            )
        body.append(
            table(
                ["key", "trials", "used", "combined period [s]", "σ"],
                krows,
                "periods",
                "table-periods",
                "Combined periods",
            )
        )
    return section("trials", "Trials", body)


def _timeline_time_cell(t: float | None) -> Raw:
    if t is None:
        return Raw('<td class="num" data-value="none">before any result</td>')
    return number_cell(t, ".1f")


def timeline_section(subject: Subject) -> Raw:
    """For a bag, what happened when on the rig's clock, each thing once; otherwise a note."""
    if subject.kind != "bag":
        return section("timeline", "Timeline", [_p("Not a recorded session: the input has no timeline.", "note")])
    body: list[str] = []
    starts = [t.start_s for t in subject.trials if t.start_s is not None]
    stops = [t.stop_s for t in subject.trials if t.stop_s is not None]
    span = f"; its trials span {max(stops) - min(starts):.1f} s of rig time" if starts and stops else ""
    if subject.duration_s is not None:
        body.append(_p(f"The recording lasted {subject.duration_s:.1f} s (the computer's clock){span}."))
    if not subject.timeline:
        body.append(_p("The bag records no trial start or stop times.", "note"))
    else:
        rows: list[list[str]] = [
            [_timeline_time_cell(e.time_s), e.what, _time_cell(e.last_s) if e.count > 1 else Raw("<td></td>")]
            for e in subject.timeline
        ]
        head = [f"time [{TIME_BASE}]", "what", "last [s]"]
        body.append(table(head, rows, "timeline", "table-timeline", "What happened when, each thing once"))
        body.append(
            _p(
                "One clock: the rig's, from the first trial's start (the trials table uses it too). Trial events "
                "are at their own stamps. The parameter and model nodes stamp with the computer's clock, which "
                "the simulated rig outruns when it runs faster than real time, so a parameter set is placed at "
                "the stop of the newest trial it includes, the model with its parameter set, and the static "
                "readings with the newest parameter set published before them. Repeated publications of the "
                "same thing (latched results re-published, a parameter set after every trial) are one row: "
                "how often, the first time and the last.",
                "note",
            )
        )
    return section("timeline", "Timeline", body)


def readings_section(subject: Subject) -> Raw:
    """Every raw reading with σ (the budget's inputs), folded away by default."""
    m = subject.measurements
    if m is None:
        return section("readings", "Raw readings", [_p("A parameter file holds no raw readings.", "note")])
    rows: list[list[str]] = [
        [Raw(f'<td data-key="{esc(k)}">{esc(k)}</td>'), value_sigma_cells(r.value, r.sigma)]
        for k, r in m.readings.items()
    ]
    tab = table(["reading", "value", "σ"], rows, "readings", "table-readings")
    summary = f"{len(rows)} readings from {m.path} (SI units, angles in degrees where the key says so)"
    return section(
        "readings",
        "Raw readings",
        [f"<details><summary>{esc(summary)}</summary>{tab}</details>"],
    )


def _figure(number: int, f: ReportFigure) -> str:
    caption = f"<figcaption><b>Figure {number}. {esc(f.title)}.</b> {esc(f.caption)}</figcaption>"
    if f.uri is None:
        return (
            f'<figure id="fig-{esc(f.key)}" class="report-figure missing">'
            f'<p class="note">{esc(f.unavailable)}</p>{caption}</figure>'
        )
    return (
        f'<figure id="fig-{esc(f.key)}" class="report-figure">'
        f'<img src="{esc(f.uri)}" alt="{esc(f.title)}">{caption}</figure>'
    )


def figures_section(figures: Sequence[ReportFigure]) -> Raw:
    """Every figure, numbered; trial fits under their own heading."""
    model = [f for f in figures if not f.key.startswith("fit-")]
    fits = [f for f in figures if f.key.startswith("fit-")]
    body = [_figure(k + 1, f) for k, f in enumerate(model)]
    if fits:
        body.append('<h3 id="trial-fits">Trial fits</h3>')
        body += [_figure(len(model) + k + 1, f) for k, f in enumerate(fits)]
    missing = [f for f in figures if f.uri is None]
    if missing:
        body.insert(0, _p(f"{len(missing)} of {len(figures)} figures could not be drawn; each says why.", "note"))
    return section("figures", "Figures", body)
