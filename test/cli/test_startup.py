"""Start-up of ``bike-rig``: a command imports only what it needs, and parses as with every command."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from bike_rig.cli.main import SUBCOMMANDS, build_parser
from bike_rig.paths import config_file

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
