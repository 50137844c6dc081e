"""Tests of :func:`bike_rig.pipeline.forked.forked_map`: the same results as a plain map, with children that fail."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from bike_rig.pipeline import forked
from bike_rig.pipeline.forked import MIN_ITEMS, can_fork, forked_map

PARENT = os.getpid()
#: Each item's work, s: long enough that every process gets to take some.
WORK_S = 0.004


def square(x: int) -> tuple[int, int]:
    """``x²`` and the process that computed it (after a little work)."""
    time.sleep(WORK_S)
    return x * x, os.getpid()


def gone(pid: int) -> bool:
    """Whether no process (not even a zombie) has this pid."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.fixture
def forks(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The pids of the children forked (recorded in the parent).

    Forking is allowed whatever threads an earlier test left running (the rule about threads
    is tested on its own, with the real check).
    """
    monkeypatch.setattr(forked, "can_fork", lambda: True)
    made: list[int] = []
    real = os.fork

    def fork() -> int:
        pid = real()
        if pid:
            made.append(pid)
        return pid

    monkeypatch.setattr(forked.os, "fork", fork)
    return made


@pytest.mark.parametrize("workers", [2, 3])
def test_the_results_are_a_plain_maps_with_items_done_in_every_process(workers: int, forks: list[int]) -> None:
    items = list(range(4 * MIN_ITEMS))
    got = forked_map(square, items, workers=workers)
    assert [v for v, _ in got] == [x * x for x in items]
    assert len(forks) == workers - 1
    assert {pid for _, pid in got} == {os.getpid(), *forks}  # (each process took some)
    assert all(gone(pid) for pid in forks)  # waited for


@pytest.mark.parametrize("case", ["few items", "one worker", "another thread"])
def test_no_child_where_it_does_not_pay_or_is_not_safe(
    case: str, forks: list[int], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(forked, "can_fork", can_fork)  # (the real check)
    items = list(range(MIN_ITEMS - 1 if case == "few items" else 2 * MIN_ITEMS))
    stop = threading.Event()
    other = threading.Thread(target=stop.wait) if case == "another thread" else None
    if other is not None:
        other.start()
    try:
        got = forked_map(square, items, workers=1 if case == "one worker" else 2)
    finally:
        stop.set()
        if other is not None:
            other.join()
    assert [v for v, _ in got] == [x * x for x in items]
    assert forks == [] and {pid for _, pid in got} == {os.getpid()}


def raising_in_a_child(x: int) -> tuple[int, int]:
    if os.getpid() != PARENT:
        raise ValueError("only in the child")
    return square(x)


def dying_in_a_child(x: int) -> tuple[int, int]:
    if os.getpid() != PARENT and x >= 3:
        os._exit(3)  # a crash: nothing sent
    return square(x)


@pytest.mark.parametrize("fn", [raising_in_a_child, dying_in_a_child])
def test_the_items_a_failing_child_took_are_done_here(fn: object, forks: list[int]) -> None:
    items = list(range(2 * MIN_ITEMS))
    got = forked_map(fn, items, workers=2)  # type: ignore[arg-type]
    assert [v for v, _ in got] == [x * x for x in items]
    assert len(forks) == 1 and gone(forks[0])
    assert {pid for _, pid in got} == {os.getpid()}  # (nothing the child took is lost)


def test_the_parents_own_failure_propagates_and_the_child_is_reaped(forks: list[int]) -> None:
    def fn(x: int) -> tuple[int, int]:
        if os.getpid() == PARENT and x >= 4:
            raise KeyError("in the parent")
        return square(x)

    with pytest.raises(KeyError, match="in the parent"):
        forked_map(fn, list(range(2 * MIN_ITEMS)), workers=2)
    assert len(forks) == 1 and gone(forks[0])


def test_ship_and_land_carry_what_a_child_sends() -> None:
    landed: list[int] = []

    def ship(x: int, result: tuple[int, int]) -> tuple[int, str]:
        return result[0], "small"

    def land(x: int, sent: object) -> tuple[int, int]:
        value, what = sent  # type: ignore[misc]
        assert what == "small"
        landed.append(x)
        return value, -1

    items = list(range(4 * MIN_ITEMS))
    got = forked_map(square, items, workers=2, ship=ship, land=land)
    assert [v for v, _ in got] == [x * x for x in items]
    assert landed and sorted(landed) == [x for x, (_, pid) in zip(items, got, strict=True) if pid == -1]
    assert {pid for _, pid in got} == {os.getpid(), -1}


def test_more_items_than_a_pipe_holds_are_mapped_here(forks: list[int]) -> None:
    items = list(range(forked.MAX_ITEMS + 1))
    got = forked_map(lambda x: (x, os.getpid()), items, workers=2)
    assert got == [(x, os.getpid()) for x in items] and forks == []
    # (the indices of MAX_ITEMS items fit the pipe at once; of twice as many they do not)
    counter = forked._Counter.of(forked.MAX_ITEMS)
    assert counter is not None
    taken = [counter.take() for _ in range(forked.MAX_ITEMS)]
    assert taken == list(range(forked.MAX_ITEMS)) and counter.take() is None
    counter.close()
    assert forked._Counter.of(2 * forked.MAX_ITEMS) is None


def open_fds() -> int:
    """How many file descriptors this process has open."""
    return len(os.listdir("/proc/self/fd"))


def test_nothing_is_left_open_and_a_refused_fork_maps_here(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(forked, "can_fork", lambda: True)
    items = list(range(2 * MIN_ITEMS))
    before = open_fds()
    assert [v for v, _ in forked_map(square, items, workers=3)] == [x * x for x in items]
    assert open_fds() == before

    def refuse() -> int:
        raise BlockingIOError(11, "Resource temporarily unavailable")  # (EAGAIN: a process limit)

    monkeypatch.setattr(forked.os, "fork", refuse)
    got = forked_map(square, items, workers=3)
    assert got == [(x * x, os.getpid()) for x in items] and open_fds() == before


def test_a_failure_here_with_children_blocked_writing_does_not_hang(tmp_path: Path) -> None:
    """Three processes, each child with more to send than a pipe holds, and this process fails meanwhile."""
    code = textwrap.dedent(
        """
        import os, time
        from bike_rig.pipeline import forked
        forked.can_fork = lambda: True
        parent = os.getpid()

        def fn(x):
            if os.getpid() == parent and x >= 6:
                time.sleep(0.3)  # (the children meanwhile take the rest, and block writing it)
                raise KeyError("here")
            time.sleep(0.001)
            return x

        try:
            forked.forked_map(fn, list(range(200)), workers=3, ship=lambda x, r: os.urandom(4096))
        except KeyError:
            try:
                os.waitid(os.P_ALL, 0, os.WEXITED | os.WNOHANG)
            except ChildProcessError:
                print("raised, no child left")
        """
    )
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env, check=False)
    assert out.stdout.strip() == "raised, no child left", out.stderr
