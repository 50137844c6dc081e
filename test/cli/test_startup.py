"""Start-up of ``bike-rig``: a command imports only what it needs, and parses as with every command.

``bike-rig --help`` and an unknown sub-command's error import no sub-command's module, yet show what
the parser with every sub-command registered shows.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from bike_rig.bag.simulated import live_results, simulated_messages, write_simulated_bag
from bike_rig.cli.commands import COMMANDS, HELP
from bike_rig.cli.main import build_overview_parser, build_parser, main
from bike_rig.config.paths import config_file
from test.support.simulated import short_session

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("scipy", "matplotlib", "rosbags", "rclpy")


def modules_after(code: str) -> set[str]:
    """The top-level packages imported once ``code`` ran in a fresh interpreter."""
    script = f"import sys\n{code}\nprint(' '.join(sorted({{m.split('.')[0] for m in sys.modules}})))"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=REPO)
    return set(out.stdout.split())


def test_importing_the_command_line_imports_no_library() -> None:
    loaded = modules_after("import bike_rig.cli.main")
    assert not loaded & {*HEAVY, "numpy", "yaml"}


def test_params_imports_neither_scipy_nor_matplotlib_nor_rosbags() -> None:
    bicycle = str(config_file("bicycles/browser.yaml"))
    code = (
        "import contextlib, io\nfrom bike_rig.cli.main import main\n"
        f"with contextlib.redirect_stdout(io.StringIO()): main(['params', {bicycle!r}])"
    )
    assert not modules_after(code) & set(HEAVY)


def subparser(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices[name]  # type: ignore[no-any-return]


@pytest.mark.parametrize("name", [command.name for command in COMMANDS])
def test_a_command_parses_as_with_every_command_registered(name: str) -> None:
    alone, every = subparser(build_parser(name), name), subparser(build_parser(), name)
    assert alone.format_help() == every.format_help()


def test_help_lists_every_command() -> None:
    text = build_parser().format_help()
    assert "{" + ",".join(command.name for command in COMMANDS) + "}" in text


def command_modules(loaded: set[str]) -> set[str]:
    """The sub-command modules (``bike_rig.cli.*_cmd``) among the modules ``loaded``."""
    return {m for m in loaded if m.startswith("bike_rig.cli.") and m.endswith("_cmd")}


def after_main(argv: list[str]) -> tuple[int, str, set[str]]:
    """Exit status, standard output and every imported module once ``main(argv)`` ran in a fresh interpreter."""
    code = (
        "import contextlib, io, json, sys\nfrom bike_rig.cli.main import main\nout = io.StringIO()\n"
        "try:\n"
        f"    with contextlib.redirect_stdout(out): status = main({argv!r})\n"
        "except SystemExit as exc:\n    status = exc.code\n"
        "print(json.dumps([status, out.getvalue(), sorted(sys.modules)]))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO)
    status, out, modules = json.loads(done.stdout)
    return status, out, set(modules)


@pytest.mark.parametrize(("argv", "status"), [(["--help"], 0), (["nosuchcommand"], 2), ([], 2)])
def test_help_and_an_unknown_command_import_no_command_module_nor_library(argv: list[str], status: int) -> None:
    got, out, loaded = after_main(argv)
    assert got == status
    assert not {m.split(".")[0] for m in loaded} & {*HEAVY, "numpy", "yaml"}
    assert not command_modules(loaded)
    if argv == ["--help"]:
        shown = "".join(out.split())  # (the help is wrapped to the terminal's width)
        for command in COMMANDS:
            assert "".join(command.help.split()) in shown


def test_a_command_imports_its_own_module_alone() -> None:
    _, _, loaded = after_main(["fit", "--help"])
    assert command_modules(loaded) == {"bike_rig.cli.fit_cmd"}


@pytest.mark.parametrize("columns", ["40", "80", "200"])
def test_the_overview_shows_the_help_of_the_parser_with_every_command(
    columns: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", columns)
    assert build_overview_parser().format_help() == build_parser().format_help()
    assert build_overview_parser().format_usage() == build_parser().format_usage()


def test_each_command_registers_the_one_line_help_of_the_table() -> None:
    action = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert {choice.dest: choice.help for choice in action._choices_actions} == HELP


def outcome(parse: Callable[[list[str]], object], argv: list[str]) -> tuple[object, str, str]:
    """Exit status (or the command parsed), standard output and standard error of ``parse(argv)``."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            result = parse(argv)
        except SystemExit as exc:
            result = exc.code
    return result, out.getvalue(), err.getvalue()


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["--help"],
        ["-h", "params"],
        ["--he"],
        ["nosuchcommand"],
        ["nosuchcommand", "--help"],
        ["-x"],
        ["-x", "params", "file.yaml"],
        ["--", "params"],
        ["--", "params", "--help"],
        ["--", "nosuchcommand"],
    ],
)
def test_a_command_line_not_starting_with_a_command_ends_as_with_every_command_registered(argv: list[str]) -> None:
    """``main``'s overview then one command's parser: the same output and status as the whole parser."""
    whole = outcome(lambda a: build_parser().parse_args(a), argv)
    assert isinstance(whole[0], int)  # each of these ends in help or a usage error
    assert outcome(main, argv) == whole


def blas_threads_after(argv: list[str], as_command: bool, threads: str | None = None) -> str:
    """``OPENBLAS_NUM_THREADS`` once ``bike-rig ARGV`` ran in a fresh interpreter (run as the command or called)."""
    call = "main()" if as_command else f"main({argv!r})"
    code = (
        "import contextlib, io, os, sys\nfrom bike_rig.cli.main import main\n"
        f"sys.argv = ['bike-rig', *{argv!r}]\n"
        f"with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()): {call}\n"
        "print(os.environ.get('OPENBLAS_NUM_THREADS', '-'))"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if threads is not None:
        env["OPENBLAS_NUM_THREADS"] = threads
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO, env=env)
    return out.stdout.strip()


def test_replay_run_as_a_command_asks_for_one_blas_thread_unless_told(tmp_path: Path) -> None:
    missing = str(tmp_path / "no-bag")
    assert blas_threads_after(["replay", missing], as_command=True) == "1"
    assert blas_threads_after(["replay", missing], as_command=True, threads="3") == "3"
    assert blas_threads_after(["replay", missing], as_command=False) == "-"  # called from Python: untouched
    assert blas_threads_after(["params", str(config_file("bicycles/browser.yaml"))], as_command=True) == "-"


def test_replay_gives_the_same_output_with_blas_threads(tmp_path: Path) -> None:
    session = short_session()
    bag = write_simulated_bag(tmp_path / "session", session, extra=live_results(simulated_messages(session)))
    outputs = []
    for threads in (None, "2"):
        env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
        if threads is not None:
            env["OPENBLAS_NUM_THREADS"] = threads
        argv = [sys.executable, "-m", "bike_rig.cli.main", "replay", str(bag), "--json"]
        outputs.append(subprocess.run(argv, capture_output=True, text=True, check=True, cwd=REPO, env=env).stdout)
    assert outputs[0] == outputs[1]
    assert '"identical": true' in outputs[0]
