"""The command line run in the test process: `bike-rig ...` through its entry point, output captured."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

from bike_rig.cli.main import main


def run_cli(*argv: str) -> tuple[int, str, str]:
    """``bike-rig ...`` through the real entry point: (status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """``bike-rig ...`` through the entry point, its output read from ``capsys``: (status, stdout, stderr)."""
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def bad(capsys: pytest.CaptureFixture[str], path: Path, *expected: str, command: str = "params") -> str:
    """Run ``command`` on ``path``; assert a one-line error naming the file and ``expected``, status 2."""
    code, out, err = run(capsys, command, str(path))
    assert code == 2, err
    assert out == ""
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert str(path) in err
    for e in expected:
        assert e in err, (e, err)
    return err
