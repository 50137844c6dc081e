"""``bike-rig bag``: look into a recorded session, and repair one whose recording was cut.

``bag info BAG [--json]`` summarises the bicycle, every trial (key, state, samples recorded and
announced, the estimate's validity), every topic (count, type), the duration and what the live
graph published last. ``bag recover BAG [-o OUT] [--json]`` rewrites what can be read of a bag
whose recorder was killed into a new bag (default ``<BAG>_recovered``) with the messages per
topic, exit 1 when a storage file or a non-CDR channel could not be recovered. BAG is a bag
directory or its ``.mcap`` file. Problems: one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import json
import math
from datetime import UTC, datetime
from pathlib import PurePath
from typing import Any

from ..bag.order import split_order
from ..bag.recover import Recovery, recover_bag
from ..core.textfmt import terminal_safe
from ..offline.info import BagSummary, TrialSummary, summarize
from .commands import HELP
from .format import format_value_sigma

__all__ = ["add_parser", "info_text", "recover_text", "run_info", "run_recover"]


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``bag info`` and ``bag recover`` on ``subparsers`` (``bike-rig``'s sub-commands)."""
    q = subparsers.add_parser(
        "bag",
        help=HELP["bag"],
        description="Tools for the rig's bags (rosbag2 directories with MCAP storage).",
    )
    sub = q.add_subparsers(dest="bag_command", required=True, metavar="{info,recover}")
    i = sub.add_parser(
        "info",
        help="the session in a bag: bicycle, trials, topics, duration, live results",
        description="Summarise a recorded session: the bicycle, every trial with its measurement key, "
        "samples and validity, every topic with its type and message count, and the duration.",
    )
    i.add_argument("bag", metavar="BAG", help="bag directory (or its .mcap file)")
    i.add_argument("--json", action="store_true", help="one JSON object on standard output")
    i.set_defaults(func=run_info)
    r = sub.add_parser(
        "recover",
        help="make the bag of a killed recorder readable again",
        description="Rewrite every readable message of a bag whose recording did not end cleanly (no "
        "metadata.yaml, an MCAP file without summary or footer) into a new, valid bag. The bag "
        "itself is left untouched.",
    )
    r.add_argument("bag", metavar="BAG", help="bag directory (or its .mcap file)")
    r.add_argument("-o", "--output", metavar="OUT", help="the new bag directory (default: BAG_recovered)")
    r.add_argument("--json", action="store_true", help="one JSON object on standard output")
    r.set_defaults(func=run_recover)


# ---------------------------------------------------------------- info


def run_info(args: argparse.Namespace) -> int:
    """``bike-rig bag info``."""
    summary = summarize(args.bag)
    if args.json:
        print(json.dumps(summary.to_dict(), indent=2, allow_nan=False))
    else:
        print(terminal_safe(info_text(summary)))
    return 0


def _time(ns: int) -> str:
    return datetime.fromtimestamp(ns / 1e9, tz=UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def _duration(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, s = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {s:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min {s:02d} s"


def _size(n: int) -> str:
    if n < 0:
        return "size unknown"
    if n < 1000:
        return f"{n} B"
    value = float(n)
    for unit in ("kB", "MB", "GB"):
        value /= 1000
        if value < 1000 or unit == "GB":
            break
    return f"{value:.1f} {unit}"


def _validity(t: TrialSummary) -> str:
    if not t.estimated:
        return "no estimate"
    if t.usable:
        return "valid"
    if t.valid:
        return "flagged: " + ", ".join(t.flags)
    return "invalid: " + (", ".join(t.flags) or "no period")


def _period(t: TrialSummary) -> str:
    if not math.isfinite(t.period):
        return "-"
    v, s = format_value_sigma(t.period, t.period_sigma, digits=None)
    return f"{v} ± {s}"


def info_text(summary: BagSummary) -> str:
    """The ``bag info`` table."""
    out = [f"bag:        {summary.path}"]
    files = ", ".join(f"{name} ({_size(size)})" for name, size in summary.files)
    out.append(f"storage:    {files}")
    out.append(f"bicycle:    {summary.bicycle or '(not recorded)'}")
    if summary.message_count:
        out.append(
            f"recorded:   {_time(summary.start_ns)} to {_time(summary.end_ns)} "
            f"({_duration(summary.duration_s)}), {summary.message_count} messages"
        )
    else:
        out.append("recorded:   no messages")
    out.append(
        "static:     "
        + ("no StaticReadings message" if summary.static_readings is None else f"{summary.static_readings} readings")
    )
    out.append("")
    width = max(len("topic"), *(len(t.name) for t in summary.topics))
    twidth = max(len("type"), *(len(t.msgtype) for t in summary.topics))
    out.append(f"{'topic':<{width}}  {'type':<{twidth}}  {'messages':>8}")
    out += [f"{t.name:<{width}}  {t.msgtype:<{twidth}}  {t.count:>8}" for t in summary.topics]
    out.append("")
    trials = summary.trials
    if not trials:
        out.append("trials:     none recorded")
    else:
        usable = sum(1 for t in trials if t.usable)
        estimated = sum(1 for t in trials if t.estimated)
        keys = len({t.measurement_key for t in trials if t.measurement_key})
        out.append(
            f"trials:     {len(trials)} for {keys} measurement keys; period estimates: {usable} valid, "
            f"{estimated - usable} flagged or invalid, {len(trials) - estimated} none"
        )
        w = max(len("trial"), *(len(t.trial_id) for t in trials))
        head = (
            f"{'trial':<{w}}  {'key':<5}  {'state':<11}  {'samples':>8}  {'announced':>9}  "
            f"{'duration':>9}  {'period [s]':>20}  validity"
        )
        out += [head, "-" * len(head)]
        for t in trials:
            announced = "-" if t.announced is None else str(t.announced)
            dur = f"{t.duration_s:.1f} s" if math.isfinite(t.duration_s) else "-"
            out.append(
                f"{t.trial_id:<{w}}  {t.measurement_key or '-':<5}  {t.state:<11}  {t.samples:>8}  {announced:>9}  "
                f"{dur:>9}  {_period(t):>20}  {_validity(t)}"
            )
    if summary.stray_batches:
        out.append(f"({summary.stray_batches} gyro batches outside any trial)")
    out.append("")
    out.append("live results: " + _live_text(summary))
    return "\n".join(out)


def _live_text(summary: BagSummary) -> str:
    live = summary.live
    if not live.parameter_sets:
        return "no parameter set recorded"
    if live.complete:
        text = f"parameter set complete ({live.com_method} mass centres)"
    else:
        text = f"parameter set incomplete, missing {', '.join(live.missing)}"
    if live.weave_speed is not None or live.capsize_speed is not None:

        def speed(v: float | None) -> str:
            return "none" if v is None else f"{v:.4f} m/s"

        rider = f" (rider {live.rider})" if live.rider else ""
        text += f"; weave {speed(live.weave_speed)}, capsize {speed(live.capsize_speed)}{rider}"
    return text


# ---------------------------------------------------------------- recover


def run_recover(args: argparse.Namespace) -> int:
    """``bike-rig bag recover``: 0, or 1 when a storage file is missing or a channel was left out."""
    recovery = recover_bag(args.bag, args.output)
    if args.json:
        print(json.dumps(_recover_json(recovery), indent=2))
    else:
        print(terminal_safe(recover_text(recovery)))
    return 1 if recovery.missing or recovery.skipped else 0


def _recover_json(r: Recovery) -> dict[str, Any]:
    return {
        "bag": r.source,
        "output": str(r.output),
        "was_complete": r.was_complete,
        "message_count": r.message_count,
        "lost_bytes": r.lost_bytes,
        "last_time_ns": r.last_time,
        "topics": [{"name": t.name, "type": t.msgtype, "recovered": t.count} for t in r.topics],
        "files": [
            {
                "file": s.path.name,
                "size": s.size,
                "read_bytes": s.read_bytes,
                "complete": s.complete,
                "chunks": s.chunks,
                "bad_chunks": s.bad_chunks,
                "stop_reason": s.stop_reason,
            }
            for s in r.files
        ],
        "skipped": list(r.skipped),
        "missing": [{"file": m.name, "why": m.why} for m in r.missing],
        "nothing_lost": r.nothing_lost,
        "notes": list(r.notes),
    }


def recover_text(r: Recovery) -> str:
    """The ``bag recover`` report."""
    out = [f"recovered {r.message_count} messages from {r.source} into {r.output}"]
    nothing_lost = r.nothing_lost
    files: list[tuple[str, str]] = []
    for s in r.files:
        if s.complete:
            state = "complete (it had its footer: nothing was lost)" if nothing_lost else "complete (it had its footer)"
        else:
            state = (
                f"cut after byte {s.read_bytes} of {s.size}: {s.stop_reason}; "
                f"{s.size - s.read_bytes} bytes after the last complete record lost"
            )
        bad = f", {s.bad_chunks} corrupt chunk(s) skipped" if s.bad_chunks else ""
        files.append((s.path.name, f"  {s.path.name}: {s.chunks} chunks read{bad}; {state}"))
    files += [(m.name, f"  {m.name}: MISSING ({m.why}): its messages are not recovered") for m in r.missing]
    out += [line for _, line in sorted(files, key=lambda f: split_order(PurePath(f[0])))]
    if r.last_time:
        out.append(f"  last message recovered: {_time(r.last_time)} ({r.last_time} ns)")
    if r.topics:
        width = max(len("topic"), *(len(t.name) for t in r.topics))
        out.append(f"{'topic':<{width}}  {'recovered':>9}  type")
        out += [f"{t.name:<{width}}  {t.count:>9}  {t.msgtype}" for t in r.topics]
    out += [f"skipped {s}" for s in r.skipped]
    out += [f"note: {n}" for n in r.notes]
    if r.missing:
        names = ", ".join(m.name for m in r.missing)
        out.append(f"NOT recovered: {len(r.missing)} storage file(s) missing ({names})")
    if r.skipped:
        out.append(f"NOT recovered: {len(r.skipped)} channel(s) that are not ROS 2 CDR (skipped above)")
    return "\n".join(out)
