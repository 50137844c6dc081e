"""``bike-rig ride``: measured weave eigenvalues of ride records, and their validation against the model.

::

    bike-rig ride fit RECORD... [--signal COL] [--time COL] [--speed M/S] [--speed-column COL]
                      [--torque-column COL] [--topic T] [--field F] [--speed-topic T] [--torque-topic T]
                      [--segments auto|whole|find] [--model auto|eq23_trend|eq23_real|eq23] [--json] [-o DIR]
    bike-rig ride validate PARAMETERS RECORD... [the record options] [--rider R] [--feedback F]
                      [--sigma correlated|paper] [--com-method M] [--speeds START STOP N] [--json] [-o DIR]
    bike-rig ride calibrate PARAMETERS RECORD... [the record options] [--rider R] [--feedback F]
                      [--free NAME,...] [--assist-rate HZ] [--com-method M] [--speeds START STOP N]
                      [--json] [-o DIR]
    bike-rig ride simulate PARAMETERS --speed M/S -o OUT.csv|OUT_BAG [--rider R] [--feedback F]
                      [--duration S] [--rate HZ] [--kick-every S] [--kick-torque NM] [--noise RAD/S] [--seed N]

A RECORD is a CSV file (:mod:`bike_rig.core.ride.record`) or a bag (a directory or ``.mcap``:
:mod:`bike_rig.bag.ride`). ``--segments whole`` fits the whole record as one free decay (as
labs store them), ``find`` segments it (:mod:`bike_rig.core.ride.segment`), ``auto`` (default)
does ``whole`` for records shorter than 5 s and ``find`` otherwise. ``--speed`` applies to
every record; else each segment's mean of the speed column or topic. ``fit --json`` prints a
list with one object per segment: ``file, segment, start, stop, speed, real, real_sigma, imag,
imag_sigma, valid, flags, n_cycles, model, start_reason, stop_reason, notes`` (s, m/s, 1/s; null for
unknown). ``validate --json`` prints ``{"segments": [... plus predicted_real,
predicted_real_sigma, predicted_imag, predicted_imag_sigma, normalised_deviation,
normalised_deviation_real, normalised_deviation_imag, verdict, verdict_text, verdict_sigma,
model_sigma_method], "predicted_real": [per segment], ..., "speeds": [per speed, combined, the same
keys; speeds without a clean segment too], "normalised_deviation": overall, "notes": [...],
"verdict", "verdict_text", "verdict_sigma"}``; the text ends in the verdict in words, never a NaN
(:mod:`bike_rig.core.ride.verdict`). Exit status 0 whenever it ran, whatever the verdict. ``-o DIR``
writes the figures (``ride_validation.png``, ``segments_<record>.png``).

``calibrate`` takes the measured parameter set and its covariance as the prior and the speeds'
combined eigenvalues as the data, and compares model variants (the rider aboard or not where
``--rider`` is given; the nominal gains or a free gain scale where ``--feedback`` is given;
with the parameters named by ``--free`` freed from their prior; ``--assist-rate`` models a
digital assist that holds its torque over each sample): each variant's posterior,
χ² with its degrees of freedom, AIC, BIC and Laplace evidence, then the verdict in words
(:mod:`bike_rig.pipeline.ride_calibrate`, :mod:`bike_rig.core.ride.variants`). ``-o DIR`` writes
``ride_calibration.png``; ``--json`` prints everything (every variant's parameters with prior and
posterior σ, covariance, criteria, linearity check; the bands).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..core.ride.eigen import MODELS, MeasuredEigenvalue, combine_eigenvalues
from ..core.ride.record import RideRecord
from ..core.ride.segment import Segment
from ..core.symbols import PARAMETER_NAMES
from ..core.textfmt import format_uncertain, terminal_safe
from ..offline.rides import WHOLE_BELOW_S, RecordOptions, measure_records
from .commands import HELP
from .common import UsageError

if TYPE_CHECKING:
    from ..core.benchmark import ParameterSet
    from ..core.feedback import Feedback

__all__ = ["add_parser", "measure", "segment_json"]


def _record_options(q: argparse.ArgumentParser) -> None:
    g = q.add_argument_group("records")
    g.add_argument("--signal", help="CSV: the signal column (default roll_rate, gyro_x or angular_velocity_x)")
    g.add_argument("--time", help="CSV: the time column, seconds or ISO 8601 (default time, t, time_s or timestamp)")
    g.add_argument("--speed", type=float, metavar="M/S", help="the speed of every record, m/s")
    g.add_argument("--speed-column", help="CSV: the speed column, m/s (default speed or speed_mps if present)")
    g.add_argument("--torque-column", help="CSV: the steer torque column, N m (default steer_torque if present)")
    g.add_argument("--topic", help="bag: the signal's topic (default: the first sensor_msgs/Imu topic)")
    g.add_argument("--field", default="angular_velocity.x", help="bag: the signal's field (default angular_velocity.x)")
    g.add_argument("--speed-topic", help="bag: a topic with the speed, m/s (field 'data')")
    g.add_argument("--torque-topic", help="bag: a topic with the steer torque, N m (field 'data')")
    g.add_argument(
        "--segments",
        choices=["auto", "whole", "find"],
        default="auto",
        help=f"whole record, find the kicks, or auto (whole below {WHOLE_BELOW_S:g} s)",
    )
    g.add_argument(
        "--model",
        choices=list(MODELS),
        default=MODELS[0],
        help="segment model: auto (Eq 23, or with a real mode where it is significantly better) or one forced",
    )
    q.add_argument("--json", action="store_true", help="JSON on standard output")
    q.add_argument("-o", "--out", metavar="DIR", help="write the figures to this directory")


def add_parser(sub: Any) -> None:
    """Register ``bike-rig ride`` and its sub-commands."""
    from .options import add_feedback_option

    q = sub.add_parser("ride", help=HELP["ride"])
    rs = q.add_subparsers(dest="ride_command", required=True)
    f = rs.add_parser("fit", help="each segment's eigenvalue with σ and flags")
    f.add_argument("records", nargs="+", metavar="RECORD", help="CSV files or bags")
    _record_options(f)
    f.set_defaults(func=run_fit)
    v = rs.add_parser("validate", help="measured against the model's weave eigenvalue, with σ on both")
    v.add_argument("parameters", metavar="PARAMETERS", help="measurement file or parameter file")
    v.add_argument("records", nargs="+", metavar="RECORD", help="CSV files or bags")
    _record_options(v)
    _model_options(v, add_feedback_option)
    v.add_argument("--sigma", choices=["correlated", "paper"], default="correlated", help="σ convention")
    v.add_argument("--speeds", nargs=3, metavar=("START", "STOP", "N"), help="speeds of the curves, m/s")
    v.set_defaults(func=run_validate)
    c = rs.add_parser("calibrate", help="the parameters' posterior and model variants, fitted to the rides")
    c.add_argument("parameters", metavar="PARAMETERS", help="measurement file or parameter file (the prior)")
    c.add_argument("records", nargs="+", metavar="RECORD", help="CSV files or bags")
    _record_options(c)
    _model_options(c, add_feedback_option)
    c.add_argument(
        "--free",
        default="",
        metavar="NAME,...",
        help="parameters freed from their prior in further variants, e.g. IBzz,IFyy",
    )
    c.add_argument("--speeds", nargs=3, metavar=("START", "STOP", "N"), help="speeds of the bands, m/s")
    rate_help = "a digital assist's sample rate, Hz: torque held over each sample (default: --feedback's rate_hz)"
    c.add_argument("--assist-rate", type=float, metavar="HZ", help=rate_help)
    c.set_defaults(func=run_calibrate)
    s = rs.add_parser("simulate", help="a simulated ride of the linear model (CSV, or a bag for a directory name)")
    s.add_argument("parameters", metavar="PARAMETERS", help="measurement file or parameter file")
    _model_options(s, add_feedback_option)
    s.add_argument("--speed", type=float, required=True, metavar="M/S", help="forward speed, m/s")
    s.add_argument("-o", "--out", required=True, help="OUT.csv, or a new bag directory (no .csv suffix)")
    s.add_argument("--duration", type=float, default=30.0, help="s (default 30)")
    s.add_argument("--rate", type=float, default=100.0, help="sample rate, Hz (default 100)")
    s.add_argument("--kick-every", type=float, default=6.0, help="s between kicks (default 6)")
    s.add_argument("--kick-torque", type=float, default=5.0, help="steer torque of a 0.1 s kick, N m (default 5)")
    s.add_argument("--noise", type=float, default=0.01, help="σ of the roll-rate sensor, rad/s (default 0.01)")
    s.add_argument("--seed", type=int, default=0)
    raw = "instead: a whole raw log (riding off and on, turns, N lateral pushes; roll rate and wheel speed; CSV)"
    s.add_argument("--raw-log", type=int, metavar="N", help=raw)
    s.set_defaults(func=run_simulate)


def _model_options(q: argparse.ArgumentParser, add_feedback_option: Any) -> None:
    from ..core.benchmark import ComMethod

    q.add_argument("--rider", help="'paper' for the paper's rigid rider (Table 1), or a rider YAML file")
    add_feedback_option(q)
    q.add_argument("--com-method", choices=[m.value for m in ComMethod], default=ComMethod.CENTROID.value)


def measure(args: argparse.Namespace) -> list[tuple[MeasuredEigenvalue, Segment, RideRecord]]:
    """Every record's segments fitted, in order (:func:`bike_rig.offline.rides.measure_records`).

    Raises:
        RideOptionError: A negative or non-finite ``--speed``. RideDataError, BagError: a bad record.
    """
    options = RecordOptions(
        args.signal,
        args.time,
        args.speed,
        args.speed_column,
        args.torque_column,
        args.topic,
        args.field,
        args.speed_topic,
        args.torque_topic,
        args.segments,
        args.model,
    )
    rows = [(m.eigenvalue, m.segment, m.record) for m in measure_records(args.records, options)]
    for record in {id(r): r for _, _, r in rows}.values():
        for text in record.notes:
            print(terminal_safe(f"note: {record.source}: {text}"), file=sys.stderr)
    for path in sorted(set(args.records) - {m.source for m, _, _ in rows}):
        from ..core.ride.segment import why_no_segment
        from ..offline.rides import load_record

        note = f"note: {path}: no segment: {why_no_segment(load_record(path, options))}"
        print(terminal_safe(note), file=sys.stderr)
    return rows


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def segment_json(m: MeasuredEigenvalue, seg: Segment) -> dict[str, Any]:
    """One segment's object (module docstring)."""
    return {
        "file": m.source,
        "segment": m.index,
        "start": _num(seg.start),
        "stop": _num(seg.stop),
        "speed": _num(m.speed),
        "real": _num(m.real),
        "real_sigma": _num(m.real_sigma),
        "imag": _num(m.imag),
        "imag_sigma": _num(m.imag_sigma),
        "valid": m.valid,
        "flags": list(m.flags),
        "n_cycles": _num(m.n_cycles),
        "model": m.model,
        "start_reason": seg.start_reason,
        "stop_reason": seg.stop_reason,
        "notes": list(m.notes),
    }


def _pm(x: float, s: float) -> str:
    """``x ± σ``; "—" without a value, "(no σ)" without a σ (never NaN)."""
    if not math.isfinite(x):
        return "—"
    if not (math.isfinite(s) and s > 0):
        return f"{x:+.3f} (no σ)"
    from ..core.textfmt import format_value_sigma

    v, sigma = format_value_sigma(x, s, digits=None)
    return f"{v if v.startswith('-') else '+' + v} ± {sigma}"


#: Normalised deviation (RMS) above which a ride without ``--rider`` gets a hint to add one.
RIDER_HINT_DEVIATION = 3.0


def _model_echo(args: argparse.Namespace) -> str:
    """Which bicycle, rider and feedback the model used, in one line."""
    from ..core.feedback import feedback_key

    rider = args.rider if args.rider not in (None, "", "none") else "none (the bicycle alone)"
    fb = feedback_key(args.feedback) or "none (open loop)"
    return f"model: {args.parameters}, rider {rider}, feedback {fb}"


def _rider_hint(args: argparse.Namespace, deviation: float) -> str | None:
    """A hint to add ``--rider`` when none was given and the model is far from the ride."""
    if args.rider not in (None, "", "none") or not (math.isfinite(deviation) and deviation > RIDER_HINT_DEVIATION):
        return None
    return (
        f"hint: the model has no rider (deviation {deviation:.1f} σ); a ridden record needs "
        "--rider paper or --rider RIDER.yaml"
    )


def _line(m: MeasuredEigenvalue, seg: Segment) -> str:
    speed = f"{m.speed:.2f} m/s" if math.isfinite(m.speed) else "speed unknown"
    head = f"{m.source} #{m.index} {seg.start:.2f}–{seg.stop:.2f} s, {speed}:"
    if not m.valid:
        return f"{head} no eigenvalue ({'; '.join(m.flags)})"
    flags = f"  flags: {'; '.join(m.flags)}" if m.flags else ""
    eig = f"Re λ {_pm(m.real, m.real_sigma)} 1/s, Im λ {_pm(m.imag, m.imag_sigma)} rad/s"
    return f"{head} {eig}, {m.n_cycles:.1f} cycles{flags}"


def _figures_dir(out: str) -> Path:
    from ..plots.output import check_out_dir

    return check_out_dir(out)


def _bicycle(args: argparse.Namespace) -> tuple[ParameterSet, Feedback | None]:
    """The parameter set of ``PARAMETERS`` with ``--rider`` added, and ``--feedback`` (or None).

    Raises:
        BikeRigError: An unreadable input, rider or feedback file (one line).
    """
    from ..core.rider import add_rider
    from .common import feedback_from_spec, rider_from_spec
    from .main import _parameters

    ps = _parameters(args.parameters, args.com_method)
    rider = rider_from_spec(args.rider)
    return (ps if rider is None else add_rider(ps, rider)), feedback_from_spec(args.feedback)


def _segment_figures(rows: list[tuple[MeasuredEigenvalue, Segment, RideRecord]], out: Path) -> None:
    import matplotlib.pyplot as plt

    from ..plots.output import slug
    from ..plots.ride import ride_segments
    from ..plots.style import save_figure

    records: dict[str, tuple[RideRecord, list[Segment]]] = {}
    for _, seg, rec in rows:
        records.setdefault(rec.source, (rec, []))[1].append(seg)
    for name, (rec, segs) in records.items():
        fig = ride_segments(rec, segs)
        save_figure(fig, out / f"segments_{slug(Path(name).stem)}", ("png",))
        plt.close(fig)


def run_fit(args: argparse.Namespace) -> int:
    """``bike-rig ride fit``; returns 0."""
    rows = measure(args)
    if args.json:
        print(json.dumps([segment_json(m, seg) for m, seg, _ in rows], indent=2))
    else:
        for m, seg, _ in rows:
            print(terminal_safe(_line(m, seg)))
        for c in combine_eigenvalues([m for m, _, _ in rows]):
            if c.n_used:
                print(
                    f"{c.speed:.2f} m/s, {c.n_used} segments combined ({c.n_left_out} left out): "
                    f"Re λ {_pm(c.real, c.real_sigma)} 1/s, Im λ {_pm(c.imag, c.imag_sigma)} rad/s"
                )
    if args.out:
        _segment_figures(rows, _figures_dir(args.out))
    return 0


def run_validate(args: argparse.Namespace) -> int:
    """``bike-rig ride validate``; returns 0.

    Raises:
        RideSpeedError: A segment without a speed.
    """
    from ..pipeline.ride import validate_ride
    from .main import _speeds

    ps, fb = _bicycle(args)
    rows = measure(args)
    speeds = _speeds(args.speeds) if args.speeds else None
    comparison, curve = validate_ride(ps, [m for m, _, _ in rows], fb, args.sigma, speeds)
    hint = _rider_hint(args, comparison.overall)
    if args.json:
        print(json.dumps(_validate_json(comparison, rows), indent=2))
    else:
        print(_model_echo(args))
        print(terminal_safe(_validate_text(comparison, rows)))
        if hint:
            print(hint)
    if hint and args.json:
        print(hint, file=sys.stderr)
    if args.out:
        import matplotlib.pyplot as plt

        from ..plots.ride import ride_validation
        from ..plots.style import save_figure

        out = _figures_dir(args.out)
        fig = ride_validation(comparison, curve, Path(args.parameters).stem, fb)
        save_figure(fig, out / "ride_validation", ("png",))
        plt.close(fig)
        _segment_figures(rows, out)
    return 0


def _free_names(spec: str) -> tuple[str, ...]:
    """``--free``'s names, checked.

    Raises:
        UsageError: A name that is not a benchmark parameter.
    """
    names = tuple(n.strip() for n in spec.split(",") if n.strip())
    for n in names:
        if n not in PARAMETER_NAMES:
            raise UsageError(f"--free {n}: not a benchmark parameter; one of {', '.join(PARAMETER_NAMES)}")
    return tuple(dict.fromkeys(names))


def run_calibrate(args: argparse.Namespace) -> int:
    """``bike-rig ride calibrate``; returns 0 whenever it ran, whatever the verdict.

    Raises:
        UsageError: A bad ``--free`` or ``--speeds``. RideSpeedError: a segment without a speed.
        CalibrationDataError: No clean segment.
    """
    from ..pipeline.ride_calibrate import calibrate_rides, calibration_json
    from .common import feedback_from_spec, rider_from_spec
    from .main import _parameters, _speeds

    free = _free_names(args.free)
    rate = args.assist_rate
    if rate is not None and not (math.isfinite(rate) and rate > 0):
        raise UsageError(f"--assist-rate must be a finite rate > 0 Hz, got {rate}")
    speeds = _speeds(args.speeds) if args.speeds else None
    bicycle = _parameters(args.parameters, args.com_method)
    rider, fb = rider_from_spec(args.rider), feedback_from_spec(args.feedback)
    rows = measure(args)
    rate = rate if rate is not None or fb is None else fb.rate_hz  # (the file's rate_hz by default)
    result = calibrate_rides(bicycle, [m for m, _, _ in rows], rider, fb, free, speeds, rate)
    if args.json:
        print(json.dumps(calibration_json(result), indent=2))
    else:
        print(_model_echo(args))
        print(_calibrate_text(result))
    if args.out:
        import matplotlib.pyplot as plt

        from ..plots.ride import ride_calibration
        from ..plots.style import save_figure

        fig = ride_calibration(result, Path(args.parameters).stem)
        save_figure(fig, _figures_dir(args.out) / "ride_calibration", ("png",))
        plt.close(fig)
    return 0


def _calibrate_text(result: Any) -> str:
    from ..core.ride.variants import constrained

    cal = result.calibration
    d = cal.data
    lines = [f"{len(d.speeds)} speeds with clean segments ({d.size} data values: Re λ and Im λ per speed)"]
    head = f"{'variant':<44} {'χ²':>8} {'dof':>4} {'χ²/dof':>7} {'AIC':>8} {'BIC':>8} {'−2 ln Z':>8}  gain scale"
    lines.append(head)
    for r in cal.variants:
        p = r.posterior
        scale = _pm(p.gain_scale, p.gain_scale_sigma).lstrip("+") if p.unknowns.gain_scale else "1 (nominal)"
        ev = f"{r.evidence:8.1f}" if math.isfinite(r.evidence) else f"{'n/d':>8}"
        red = f"{r.reduced_chi2:7.2f}" if math.isfinite(r.reduced_chi2) else f"{'—':>7}"
        lines.append(f"{r.name:<44} {p.chi2:8.1f} {p.dof:4d} {red} {r.aic:8.1f} {r.bic:8.1f} {ev}  {scale}")
    best = cal.best.posterior
    caveat = "" if cal.explained else " — it does not explain the rides: shifts forced onto the model, not measured"
    lines.append(
        f"best variant '{cal.best.name}': parameters that move or that the rides constrain "
        f"(prior → posterior, shift in prior σ, posterior/prior σ){caveat}:"
    )
    tight = {n for n, _ in constrained(best)}
    prior = best.prior.parameters
    for i, n in enumerate(PARAMETER_NAMES):
        if n in tight or abs(best.shifts[i]) >= 0.5 or n in best.unknowns.free:
            change = f"{best.shifts[i]:+.1f} σ, ratio {best.sigma_ratio[i]:.2f}"
            before = format_uncertain(prior.values[i], prior.sigmas[i])
            lines.append(f"    {n:<5} {before} → {format_uncertain(best.values[i], best.sigmas[i])}  ({change})")
    if lines[-1].startswith("best variant"):
        lines.append("    none: every parameter stays within 0.5 prior σ and keeps its prior σ")
    lines.append(f"verdict: {cal.verdict}")
    lines += [f"note: {n}" for n in (*cal.notes, *best.linearity.notes)]
    return "\n".join(lines)


def _verdict_json(v: Any, method: str | None = None) -> dict[str, Any]:
    out = {"verdict": v.code, "verdict_text": v.text, "verdict_sigma": _num(v.sigma)}
    return out if method is None else {**out, "model_sigma_method": method}


def _validate_json(comparison: Any, rows: list[tuple[MeasuredEigenvalue, Segment, RideRecord]]) -> dict[str, Any]:
    segments = []
    for c, (m, seg, _) in zip(comparison.segments, rows, strict=True):
        obj = segment_json(m, seg)
        obj.update(
            {
                "predicted_real": _num(c.predicted_real),
                "predicted_real_sigma": _num(c.predicted_real_sigma),
                "predicted_imag": _num(c.predicted_imag),
                "predicted_imag_sigma": _num(c.predicted_imag_sigma),
                "normalised_deviation": _num(c.deviation),
                "normalised_deviation_real": _num(c.z_real),
                "normalised_deviation_imag": _num(c.z_imag),
                **_verdict_json(c.verdict, c.sigma_method),
            }
        )
        segments.append(obj)
    keys = ("predicted_real", "predicted_real_sigma", "predicted_imag", "predicted_imag_sigma")
    speeds = [
        {
            "speed": s.combined.speed,
            "n_used": s.combined.n_used,
            "n_left_out": s.combined.n_left_out,
            "real": _num(s.combined.real),
            "real_sigma": _num(s.combined.real_sigma),
            "imag": _num(s.combined.imag),
            "imag_sigma": _num(s.combined.imag_sigma),
            **{k: _num(getattr(s, k)) for k in keys},
            "normalised_deviation": _num(s.deviation),
            "normalised_deviation_real": _num(s.z_real),
            "normalised_deviation_imag": _num(s.z_imag),
            **_verdict_json(s.verdict, s.sigma_method),
        }
        for s in comparison.speeds
    ]
    for u in comparison.unmeasured:
        speeds.append(
            {
                "speed": u.speed,
                "n_used": 0,
                "n_left_out": u.n_left_out,
                "real": None,
                "real_sigma": None,
                "imag": None,
                "imag_sigma": None,
                **dict.fromkeys(keys),
                "normalised_deviation": None,
                "normalised_deviation_real": None,
                "normalised_deviation_imag": None,
                **_verdict_json(_unmeasured_verdict(u), "none"),
            }
        )
    speeds.sort(key=lambda o: o["speed"])
    out: dict[str, Any] = {"segments": segments}
    out.update({k: [o[k] for o in segments] for k in keys})
    out.update({"speeds": speeds, "normalised_deviation": _num(comparison.overall), "notes": list(comparison.notes)})
    out.update(_verdict_json(comparison.verdict))
    return out


def _unmeasured_verdict(u: Any) -> Any:
    from ..core.ride.verdict import Verdict

    text = f"no verdict: no clean segment ({u.n_left_out} segments, each flagged or without an eigenvalue)"
    return Verdict("no_clean_segment", text, math.nan)


def _z(x: float) -> str:
    return f"{x:+.2f}" if math.isfinite(x) else "none"


def _model(c: Any) -> str:
    mc = " (Monte Carlo σ)" if c.sigma_method == "monte_carlo" else ""
    im = _pm(c.predicted_imag, c.predicted_imag_sigma)
    return f"Re λ {_pm(c.predicted_real, c.predicted_real_sigma)}, Im λ {im}{mc}"


def _validate_text(comparison: Any, rows: list[tuple[MeasuredEigenvalue, Segment, RideRecord]]) -> str:
    lines = []
    for c, (m, seg, _) in zip(comparison.segments, rows, strict=True):
        lines.append(_line(m, seg))
        if m.valid:
            lines.append(
                f"    model: {_model(c)}; normalised deviation re {_z(c.z_real)}, im {_z(c.z_imag)}: {c.verdict.text}"
            )
    per_speed: list[tuple[float, str]] = []
    for s in comparison.speeds:
        c = s.combined
        measured = f"Re λ {_pm(c.real, c.real_sigma)}, Im λ {_pm(c.imag, c.imag_sigma)}"
        used = f"{c.n_used} segments" + (f", {c.n_left_out} left out" if c.n_left_out else "")
        per_speed.append(
            (
                c.speed,
                f"{c.speed:.2f} m/s ({used}): measured {measured}; model {_model(s)}; "
                f"normalised deviation {s.deviation:.2f}: {s.verdict.text}",
            )
        )
    for u in comparison.unmeasured:
        per_speed.append((u.speed, f"{u.speed:.2f} m/s: {_unmeasured_verdict(u).text}"))
    lines += [text for _, text in sorted(per_speed)]
    overall = f"{comparison.overall:.2f}" if math.isfinite(comparison.overall) else "none (no clean segment)"
    lines.append(f"overall normalised deviation (RMS over clean segments): {overall}")
    lines.append(f"verdict: {comparison.verdict.text}")
    lines += [f"note: {n}" for n in comparison.notes]
    return "\n".join(lines)


def _simulate_raw_log(args: argparse.Namespace, ms: Any, fb: Feedback | None) -> int:
    """``ride simulate --raw-log N`` (:mod:`bike_rig.core.sim.ride_log`): assist ``fb``, else its own; returns 0."""
    from dataclasses import replace

    import numpy as np

    from ..core.sim.ride_log import ride_plan, simulate_raw_log, write_log_csv

    if args.raw_log < 0 or not args.out.lower().endswith(".csv"):
        raise UsageError(f"--raw-log needs N >= 0 pushes and an OUT.csv, got {args.raw_log} and {args.out}")
    rng = np.random.default_rng(args.seed)
    plan = ride_plan(args.duration, args.speed, args.raw_log, rng)
    plan = replace(plan, rate_hz=args.rate, noise_roll_rate=args.noise)
    if fb is not None:
        plan = replace(plan, gains=lambda v: np.asarray(fb.gains(v), dtype=float), controller_hz=fb.rate_hz)
    log = simulate_raw_log(ms.matrices, ms.g, plan, rng)
    write_log_csv(log, args.out)
    pushes = ", ".join(f"{p.time:.2f} s (free decay {p.start:.2f}–{p.stop:.2f} s)" for p in log.pushes) or "none"
    assist = f"assist {fb.name} (--feedback)" if fb is not None else "the simulator's own assist (no --feedback)"
    print(
        terminal_safe(
            f"wrote {args.out}: a {args.duration:g} s raw log at {args.speed:g} m/s, {assist}; pushes {pushes}"
        )
    )
    return 0


def run_simulate(args: argparse.Namespace) -> int:
    """``bike-rig ride simulate``; returns 0.

    Raises:
        UsageError: Bad numbers. SimulationError: an impossible ride.
    """
    from ..core.sim.ride import RideSimulation, regular_kicks, simulate_ride, write_ride_csv
    from ..core.uncertainty.matrix_sigma import canonical_with_sigma

    for name in ("speed", "duration", "rate", "kick_every", "noise"):
        x = getattr(args, name)
        if not (math.isfinite(x) and x >= 0) or (name in ("duration", "rate", "kick_every") and x <= 0):
            raise UsageError(f"--{name.replace('_', '-')} must be a finite positive number, got {x}")
    ps, fb = _bicycle(args)
    ms = canonical_with_sigma(ps)
    if args.raw_log is not None:
        return _simulate_raw_log(args, ms, fb)
    first = min(1.0, 0.2 * args.duration)
    kicks = regular_kicks(args.duration, args.kick_every, first=first, steer_torque=args.kick_torque)
    sim = RideSimulation(args.speed, args.duration, args.rate, kicks, noise_roll_rate=args.noise, seed=args.seed)
    gains = None if fb is None else fb.gains(args.speed)
    ride = simulate_ride(ms.matrices, ms.g, sim, gains, None if fb is None else fb.rate_hz)
    if args.out.lower().endswith(".csv"):
        write_ride_csv(ride, args.out)
    else:
        from ..bag.ride import write_ride_bag

        write_ride_bag(ride, args.out)
    text = f"wrote {args.out}: {len(kicks)} kicks at {args.speed:g} m/s, {args.duration:g} s at {args.rate:g} Hz"
    print(terminal_safe(text))
    return 0
