"""Waiting for a condition with a deadline: the one polling loop of the tests."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

__all__ = ["WAIT_TIMEOUT_S", "wait_until"]

T = TypeVar("T")

#: Default deadline, s: generous, so that a busy machine only makes a test slower.
WAIT_TIMEOUT_S = 60.0


def wait_until(
    condition: Callable[[], T],
    what: str,
    timeout_s: float = WAIT_TIMEOUT_S,
    interval_s: float = 0.05,
    describe: Callable[[], str] = lambda: "",
) -> T:
    """Call ``condition()`` every ``interval_s`` s until it returns a true value; return that value.

    ``condition`` may itself raise (e.g. an AssertionError when the process it waits on ended).

    Raises:
        AssertionError: After ``timeout_s`` s, naming ``what``, followed by ``describe()``.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}\n{describe()}".rstrip())
        time.sleep(interval_s)
