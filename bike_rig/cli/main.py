"""``bike-rig``: the command line. The only place that prints for users.

Every user mistake ends in one line on stderr naming the file, key, line and reason, exit status
2, no traceback. A sub-command's module is imported only when it runs: ``--help`` and the error
of a missing or unknown sub-command come from :func:`build_overview_parser`, which knows the
commands by name and one-line help (:data:`~bike_rig.cli.commands.COMMANDS`). Commands in
:data:`SINGLE_THREADED_BLAS` ask OpenBLAS for no worker threads (:func:`single_threaded_blas`).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from ..core.errors import BikeRigError
from .commands import COMMANDS, HELP

if TYPE_CHECKING:
    import numpy as np

    from ..core.benchmark import ParameterSet
    from ..core.uncertainty.mc_sigma import PrintedSigmas

__all__ = ["main"]

EXIT_USER_ERROR = 2
#: The status of a command stopped by Ctrl-C (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130
DEFAULT_BICYCLE = "bicycles/browser.yaml"

#: Sub-commands run with one OpenBLAS thread: their linear algebra is small (fits of one trial,
#: 4×4 matrices), and ``replay``'s output is the same, bit for bit (test/cli/test_startup.py).
SINGLE_THREADED_BLAS = frozenset({"replay"})


def single_threaded_blas() -> None:
    """Ask OpenBLAS for no worker threads (``OPENBLAS_NUM_THREADS=1``) unless the user chose a number.

    numpy and scipy each load their own OpenBLAS, and each starts a pool of one worker thread
    per further CPU, which spins while it waits for work. On a 2-CPU machine the two pools
    compete with the main thread for the second CPU while the imports run: ``import
    scipy.optimize`` took 0.56 s of CPU time with them and 0.38 s without, 0.42 s and 0.38 s
    of wall time (medians of 11 fresh processes). Effective only before numpy and scipy load;
    child processes inherit it.
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _parameters(path: str, com_method: str, lump_flywheel: bool = False) -> ParameterSet:
    """A parameter file, a measurement file, a session bag or a shipped bicycle's name."""
    from ..offline.subjects import load_parameters

    return load_parameters(path, com_method, lump_flywheel)


#: The fastest speed, either way, and the most speeds ``model --speeds`` evaluates (m/s; as the
#: model node's ``speed_max`` and ``speed_count``).
MODEL_MAX_SPEED, MODEL_MAX_SPEEDS = 1000.0, 100_000


def _speeds(spec: Sequence[str] | None) -> np.ndarray:
    import math

    import numpy as np

    from .common import UsageError

    if spec is None:
        return np.linspace(0.0, 10.0, 11)
    try:
        start, stop = float(spec[0]), float(spec[1])
        n = int(spec[2])
    except ValueError:
        raise UsageError(f"--speeds START STOP N: numbers expected, got {' '.join(spec)}") from None
    if not (math.isfinite(start) and math.isfinite(stop)) or n < 1 or start > stop:
        raise UsageError(f"--speeds START STOP N needs finite START <= STOP and N >= 1, got {' '.join(spec)}")
    if max(abs(start), abs(stop)) > MODEL_MAX_SPEED or n > MODEL_MAX_SPEEDS:
        raise UsageError(
            f"--speeds START STOP N: at most {MODEL_MAX_SPEED:g} m/s either way and {MODEL_MAX_SPEEDS:,} speeds "
            f"(the model's polynomials in v overflow long before float64 does), got {' '.join(spec)}"
        )
    return np.linspace(start, stop, n)


def _printed_sigmas(path: str, ps: ParameterSet, lump_flywheel: bool) -> PrintedSigmas | None:
    """The σ to print of parameters computed from raw readings (Monte Carlo where lines are nearly parallel)."""
    import warnings

    from ..core.benchmark import ComMethod
    from ..core.loader import load_input
    from ..core.measurements import Measurements
    from ..core.uncertainty.mc_sigma import printed_sigmas
    from ..offline.subjects import is_bag_path, load_subject, resolve_bicycle

    if ps.raw is None:
        return None
    p = resolve_bicycle(path)
    if is_bag_path(p):
        m = load_subject(p).measurements
    else:
        with warnings.catch_warnings():  # already shown when the parameters were computed
            warnings.simplefilter("ignore")
            got = load_input(p)
        m = got if isinstance(got, Measurements) else None
    if m is None:
        return None
    method = next(iter(ps.com.values())).used if ps.com else ComMethod.CENTROID
    return printed_sigmas(m, ps.parameters, method, lump_flywheel)


def _params_json(ps: ParameterSet, sigmas: PrintedSigmas | None = None) -> dict[str, Any]:
    pv = ps.parameters
    params: dict[str, Any] = {k: {"value": pv.value(k), "sigma": pv.sigma(k)} for k in pv.names}
    if sigmas is not None:
        for k in sigmas.monte_carlo:
            params[k].update(sigma=sigmas.sigma[k], sigma_method="monte_carlo", sigma_linear=sigmas.linear[k])
    out: dict[str, Any] = {"bicycle": ps.bicycle, "parameters": params}
    if ps.parts is not None:
        out["parts"] = {k: {"value": ps.parts.value(k), "sigma": ps.parts.sigma(k)} for k in ps.parts.names}
    return out


def cmd_params(args: argparse.Namespace) -> int:
    import json

    from . import format as fmt
    from .common import emit

    ps = _parameters(args.file, args.com_method, args.flywheel_in_wheel)
    with_rider = False
    if args.rider not in (None, "", "none"):
        from ..core.rider import add_rider
        from .common import rider_from_spec

        rider = rider_from_spec(args.rider)
        if rider is not None:
            ps = add_rider(ps, rider)
            with_rider = True
    form = "json" if args.json else args.format
    sigmas = _printed_sigmas(args.file, ps, args.flywheel_in_wheel) if not with_rider else None
    if form == "json":
        text = json.dumps(_params_json(ps, sigmas), indent=2)
    elif form == "bp-yaml":
        from ..core.io_bp import dump_bp_parameter_yaml

        text = dump_bp_parameter_yaml(ps, rider=with_rider)
    elif form == "yaml":
        from ..core.io_yaml import dump_parameters_yaml

        text = dump_parameters_yaml(ps)
    else:
        text = fmt.parameter_table(ps, sigmas)
    emit(text, args.output)
    return 0


def cmd_import_bp(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..core.io_yaml import ATTRIBUTION, dump_measurements_yaml, dump_parameters_yaml
    from ..core.loader import load_input
    from ..core.measurements import Measurements, validate

    got = load_input(args.file)
    if isinstance(got, Measurements):
        validate(got)
        text = dump_measurements_yaml(got, ATTRIBUTION)
        what = f"measurements, {len(got.readings)} readings and {len(got.extras)} other entries"
    else:
        text = dump_parameters_yaml(got, ATTRIBUTION)
        what = f"parameters, {len(got.parameters.names)} values"
    Path(args.output).write_text(text, encoding="utf-8")
    from ..core.textfmt import terminal_safe

    print(terminal_safe(f"wrote {args.output}: {got.bicycle} {what}"), file=sys.stderr)
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from ..config.paths import config_file
    from . import format as fmt

    if args.offline:
        return _demo_offline(args.bicycle or str(config_file(DEFAULT_BICYCLE)))
    from ..core.textfmt import format_speed
    from ..ros.demo import run_demo

    out = Path(args.out) if args.out else Path("bike_rig_demo") / time.strftime("%Y%m%d-%H%M%S")
    result = run_demo(
        out,
        Path(args.bicycle) if args.bicycle else None,
        seed=args.seed,
        time_scale=args.time_scale,
        progress=lambda line: print(line, flush=True),
    )
    ps = result.session.parameters
    assert ps is not None
    print()
    print(fmt.parameter_table(ps))
    print()
    st = result.stability
    print(f"weave speed:   {format_speed(st.weave, 'weave')}")
    print(f"capsize speed: {format_speed(st.capsize, 'capsize')}")
    print()
    redo = f"; trials to redo: {', '.join(sorted(result.invalid))}" if result.invalid else ""
    print(f"{result.periods} of {result.trials} trials fitted live in {result.wall_s:.1f} s{redo}")
    print(f"bag: {result.bag}  (bike-rig bag info {result.bag}; bike-rig replay {result.bag})")
    return 0


def _demo_offline(path: str) -> int:
    from ..core.rider import PAPER_RIDER, add_rider
    from ..core.uncertainty.matrix_sigma import canonical_with_sigma
    from ..core.uncertainty.speed_sigma import critical_speeds_with_sigma
    from . import format as fmt
    from .model_cmd import speeds_text

    ps = _parameters(path, "centroid")
    ridden = add_rider(ps, PAPER_RIDER)
    ms = canonical_with_sigma(ps)
    print(fmt.parameter_table(ps))
    print()
    print(fmt.matrix_table(ms))
    print()
    print(speeds_text(critical_speeds_with_sigma(ps, matrices=ms)))
    print()
    print("with the paper's rigid rider (Table 1):")
    print(speeds_text(critical_speeds_with_sigma(ridden)))
    return 0


def _common(q: argparse.ArgumentParser) -> None:
    from ..core.benchmark import ComMethod

    q.add_argument("file", help="measurement file or parameter file (our YAML or BicycleParameters text)")
    q.add_argument(
        "--com-method",
        choices=[m.value for m in ComMethod],
        default=ComMethod.CENTROID.value,
        help="mass-centre method: centroid of the line intersections (paper, default) or least squares",
    )
    q.add_argument("-o", "--output", help="write to this file instead of standard output")
    from .options import add_strict_option

    add_strict_option(q)


def _add_params(sub: Any) -> None:
    q = sub.add_parser("params", help=HELP["params"])
    _common(q)
    q.add_argument("--json", action="store_true", help="one JSON object on standard output")
    q.add_argument("--format", choices=["table", "json", "yaml", "bp-yaml"], default="table")
    q.add_argument(
        "--flywheel-in-wheel",
        action="store_true",
        help="a flywheel D measured in the front wheel turns with it: include its mass and moments in "
        "mF, IFxx, IFyy (default: the wheel alone, as BicycleParameters)",
    )
    q.add_argument(
        "--rider",
        help="lump a rider into the rear frame: 'paper' (Table 1), or a rider YAML file (rigid or Yeadon)",
    )
    q.set_defaults(func=cmd_params)


def _add_import_bp(sub: Any) -> None:
    q = sub.add_parser("import-bp", help=HELP["import-bp"])
    q.add_argument("file", help="<Name>Measured.txt or <Name>Benchmark.txt")
    q.add_argument("-o", "--output", required=True, help="the YAML file to write")
    q.set_defaults(func=cmd_import_bp)


def _add_demo(sub: Any) -> None:
    q = sub.add_parser("demo", help=HELP["demo"])
    q.add_argument("--bicycle", help="the true bicycle (default: config/bicycles/browser.yaml)")
    q.add_argument("--out", help="new directory for the session, bag and logs (default: ./bike_rig_demo/<time>)")
    q.add_argument("--seed", type=int, default=1, help="seed of the simulated session (default 1)")
    q.add_argument("--time-scale", type=float, default=25.0, help="rig seconds per wall second (default 25)")
    q.add_argument("--offline", action="store_true", help="no ROS: compute the bicycle file's parameters directly")
    q.set_defaults(func=cmd_demo)


def _registrar(where: str) -> Callable[[Any], None]:
    """The function that registers one sub-command (importing its module only now)."""
    if where.startswith("_"):
        return globals()[where]
    module = importlib.import_module(f"{__package__}.{where}")
    return module.add_parser


def _top_parser() -> tuple[argparse.ArgumentParser, argparse._SubParsersAction[argparse.ArgumentParser]]:
    """``bike-rig``'s own parser, and its (still empty) sub-command parsers."""
    p = argparse.ArgumentParser(prog="bike-rig", description="Bicycle parameter rig (Moore et al.) tools.")
    return p, p.add_subparsers(dest="command", required=True)


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of every subcommand (or of ``only``, when it names one)."""
    p, sub = _top_parser()
    for command in COMMANDS:
        if only is None or only == command.name:
            _registrar(command.registrar)(sub)
    return p


def build_overview_parser() -> argparse.ArgumentParser:
    """``bike-rig``'s parser with every sub-command known by its name and one-line help alone.

    Its help and its errors (no sub-command, an unknown one) are those of :func:`build_parser`,
    but it imports no sub-command's module. A sub-command's parser here is a placeholder that
    takes any arguments, even ``--help``: :func:`main` parses them again with the real ones.
    """
    p, sub = _top_parser()
    for command in COMMANDS:
        sub.add_parser(command.name, help=command.help, add_help=False)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``bike-rig``; returns the exit status."""
    fresh = argv is None  # run as a command, not called from Python
    argv = list(sys.argv[1:] if argv is None else argv)
    named = argv[0] if argv and argv[0] in HELP else None
    if fresh and named in SINGLE_THREADED_BLAS:
        single_threaded_blas()
    if named is None:  # --help, or no or an unknown sub-command: the overview shows it and exits
        build_overview_parser().parse_known_args(argv)
        # still here: a sub-command after "--" or an unknown option, parsed (as ever) with every one
    args = build_parser(named).parse_args(argv)
    try:
        from .unit_policy import apply_unit_policy

        apply_unit_policy(args.command, bool(getattr(args, "strict", False)))
        return int(args.func(args))
    except BikeRigError as exc:
        from ..core.textfmt import terminal_safe

        print(f"bike-rig {args.command}: error: {terminal_safe(str(exc), keep='')}", file=sys.stderr)
        return EXIT_USER_ERROR
    except BrokenPipeError:
        return 0
    except KeyboardInterrupt:  # (Ctrl-C: commands that clean up on it catch it themselves)
        print(f"bike-rig {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
