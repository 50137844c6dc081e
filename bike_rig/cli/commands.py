"""The sub-commands of ``bike-rig``: their names, where each is registered, and its one-line help.

One table, read by ``bike-rig --help`` (which imports no sub-command's module, so none of numpy,
scipy, rosbags, matplotlib...) and by each sub-command's own ``add_parser`` (its ``help=``), so
that the line is written once. A new sub-command is a module and a line here. This module imports
nothing of the project.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["COMMANDS", "HELP", "Command"]


class Command(NamedTuple):
    """One sub-command of ``bike-rig``.

    Attributes:
        name: The sub-command's name on the command line.
        registrar: The module of :mod:`bike_rig.cli` whose ``add_parser`` registers it, or the
            function of :mod:`bike_rig.cli.main` that does (a name starting with ``_``).
        help: Its one-line help, as ``bike-rig --help`` lists it.
    """

    name: str
    registrar: str
    help: str


#: The sub-commands in the order ``bike-rig --help`` lists them.
COMMANDS: tuple[Command, ...] = (
    Command("params", "_add_params", "the 25 benchmark parameters with σ"),
    Command("model", "model_cmd", "canonical matrices, critical speeds and eigenvalues"),
    Command("import-bp", "_add_import_bp", "convert a BicycleParameters text file to bike_rig YAML"),
    Command("fit", "fit_cmd", "fit the pendulum period of trial files (Eq 23-27)"),
    Command("bag", "bag_cmd", "summarise a recorded session, or recover a bag whose recording was cut"),
    Command("replay", "replay_cmd", "recompute a recorded session offline (or --republish it into a live graph)"),
    Command(
        "run",
        "run_cmd",
        "start the rig's ROS graph (driver, fitter, parameter, model, recorder) and print each trial's result",
    ),
    Command("view", "view_cmd", "serve the live ROS graph to the Foxglove app (its WebSocket protocol) until Ctrl-C"),
    Command(
        "session", "session_cmd", "run a measurement session from one console: the plan, trials, readings, results"
    ),
    Command("simulate", "simulate_cmd", "simulate a measurement session on the pendulum rig (paper sections 6-9)"),
    Command(
        "plot",
        "plot_cmd",
        "figures: eigenvalues, root locus, mode shapes, Bode, side view, trial fits and overview",
    ),
    Command("budget", "budget_cmd", "uncertainty budget: the raw readings ranked by their share of each σ"),
    Command(
        "report",
        "report_cmd",
        "a self-contained HTML report of one bicycle: parameters, matrices, speeds, budget, trials, figures",
    ),
    Command("ride", "ride_cmd", "measured weave eigenvalues of ride records, validated against the model"),
    Command(
        "demo", "_add_demo", "a whole simulated rig session through the live ROS graph: parameters, stability, bag"
    ),
)

#: Each sub-command's one-line help, by name.
HELP: dict[str, str] = {command.name: command.help for command in COMMANDS}
