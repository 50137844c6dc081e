"""`bike-rig replay` run in the test process, and the live fitter settings of the recorded test sessions."""

from __future__ import annotations

import argparse
import contextlib
import io

from bike_rig.cli import replay_cmd
from bike_rig.core.errors import BikeRigError
from bike_rig.core.period import FitOptions, WindowPolicy, combine_periods, fit_period
from bike_rig.core.sim import SimulatedSession
from bike_rig.pipeline.fit import TrialFitOptions

#: The live fitter's settings in these sessions: not the defaults, so that using the recorded
#: ones is what makes the replay identical.
LIVE_OPTIONS = TrialFitOptions(FitOptions(window=WindowPolicy.lead_in(1.5), min_r2=0.8))


def run_cli(*argv: str) -> tuple[int, str, str]:
    """``bike-rig replay ...`` as main.py runs it: BikeRigError → one line, status 2."""
    parser = argparse.ArgumentParser(prog="bike-rig")
    sub = parser.add_subparsers(dest="command", required=True)
    replay_cmd.add_parser(sub)
    args = parser.parse_args(argv)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = int(args.func(args))
        except BikeRigError as exc:
            print(f"bike-rig {args.command}: error: {exc}", file=err)
            code = 2
    return code, out.getvalue(), err.getvalue()


def core_periods(session: SimulatedSession) -> dict[str, tuple[float, float]]:
    """The offline core's periods: each trial fitted (Eq 23-27), each key's trials combined."""
    fits = {t.name: fit_period(t.rate, sample_rate_hz=t.sample_rate) for t in session.trials}
    out = {}
    for m in session.plan:
        c = combine_periods([fits[t.name] for t in session.trials_of(m.key)])
        out[m.key] = (c.value, c.sigma)
    return out
