"""Start-up of ``bike-rig``: a command imports only what it needs, and parses as with every command."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bike_rig.bag.simulated import live_results, simulated_messages, write_simulated_bag
from bike_rig.cli.main import SUBCOMMANDS, build_parser
from bike_rig.paths import config_file
from test.bag.conftest import short_session

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


@pytest.mark.parametrize("name", [name for name, _ in SUBCOMMANDS])
def test_a_command_parses_as_with_every_command_registered(name: str) -> None:
    alone, every = subparser(build_parser(name), name), subparser(build_parser(), name)
    assert alone.format_help() == every.format_help()


def test_help_lists_every_command() -> None:
    text = build_parser().format_help()
    assert "{" + ",".join(name for name, _ in SUBCOMMANDS) + "}" in text


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
