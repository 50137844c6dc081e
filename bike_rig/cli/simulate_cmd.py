"""``bike-rig simulate``: a whole simulated measurement session, written to a directory.

    bike-rig simulate --bicycle FILE --out DIR [--seed N] [--rig config/rig.yaml] [--volts] [--force]

FILE is any bicycle file ``bike-rig params`` reads (measurements or parameters); its
parameters are the truth. DIR receives ``session.yaml`` (a measurement file whose periods
list their trial files), ``trials/*.npy`` and ``truth.yaml`` (see
:mod:`bike_rig.core.sim.writer`).
"""

from __future__ import annotations

import argparse
import secrets
import sys
from pathlib import Path

from ..config.paths import config_file
from ..core.errors import BikeRigError, InputFileError
from ..core.sim import load_rig, load_true_parameters, simulate_session, write_session
from .commands import HELP

__all__ = ["DEFAULT_RIG", "add_parser", "run"]

DEFAULT_RIG = "rig.yaml"


class SimulateUsageError(BikeRigError):
    """A ``simulate`` argument is invalid."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register the ``simulate`` subcommand (``set_defaults(func=run)``)."""
    q = subparsers.add_parser(
        "simulate",
        help=HELP["simulate"],
        description="Simulate a whole measurement session of a bicycle on the rig: static readings with "
        "noise and every pendulum trial as a gyro signal, written as a session directory.",
    )
    q.add_argument("--bicycle", required=True, help="bicycle whose parameters are the truth (any file params reads)")
    q.add_argument("--out", required=True, help="session directory to write (new or empty)")
    q.add_argument("--seed", type=int, help="seed (a non-negative integer); default: a fresh one, reported")
    q.add_argument("--rig", help="rig description (default: config/rig.yaml)")
    q.add_argument("--volts", action="store_true", help="also write the raw ADC volts under DIR/volts/")
    q.add_argument("--force", action="store_true", help="write into a directory that is not empty")
    q.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Simulate and write the session; returns the exit status (errors are raised)."""
    seed = secrets.randbelow(2**32) if args.seed is None else int(args.seed)
    if seed < 0:
        raise SimulateUsageError(f"--seed must be a non-negative integer, got {seed}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputFileError(str(out), "exists and is not a directory")
    if out.is_dir() and any(out.iterdir()) and not args.force:
        raise InputFileError(str(out), "directory is not empty (use --force to write into it)")
    rig = load_rig(args.rig or config_file(DEFAULT_RIG))
    bicycle, truth = load_true_parameters(args.bicycle)
    session = simulate_session(truth, rig, seed, bicycle)
    try:
        path = write_session(session, out, volts=args.volts)
    except OSError as exc:
        raise InputFileError(str(out), f"cannot write ({exc.strerror or exc})") from None
    beating = sum(t.beating for t in session.trials)
    durations = sorted({len(t.rate) / t.sample_rate for t in session.trials})
    print(
        f"wrote {path}: {bicycle}, {len(session.trials)} trials of {'/'.join(f'{d:g}' for d in durations)} s at "
        f"{rig.adc.sample_rate:g} Hz ({beating} beating), seed {seed}",
        file=sys.stderr,
    )
    return 0
