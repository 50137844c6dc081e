"""Offline work shared with forked child processes: the fits of a session on every CPU.

The fit of a trial is Python-bound (about 1,100 numpy and Python calls per trial), so threads
do not run two at once; processes do. :func:`forked_map` maps a function over a list, this
process and n − 1 forked children taking the items one at a time, each the next one when it is
free; each child inherits the items and the function (nothing is pickled on the way in) and
sends its results back through a pipe. The results are the same as a plain map's, bit for bit:
the same code on the same data. (A forked child works slower than its parent at first: every
page it writes that it shares with the parent is copied; taking items as they come keeps both
busy to the end.)

A child is forked only where that is safe and pays: ``fork`` exists, this process may use more
than one CPU, it runs no other Python thread (forking a multi-threaded process can deadlock the
child on a lock another thread held), and there are at least :data:`MIN_ITEMS` items (and at
most :data:`MAX_ITEMS`). A child
that fails in any way (an exception, a crash, a result that does not unpickle) has the items it
took done here instead, so a failure surfaces as the plain map's would.
"""

from __future__ import annotations

import gc
import os
import pickle
import signal
import threading
from collections.abc import Callable, Sequence
from typing import NoReturn, TypeVar

__all__ = ["MAX_ITEMS", "MAX_WORKERS", "MIN_ITEMS", "can_fork", "default_workers", "forked_map"]

T = TypeVar("T")
R = TypeVar("R")

#: Most processes to work in.
MAX_WORKERS = 4
#: Fewer items than this are mapped in this process (a fork costs about what 2 trial fits do).
MIN_ITEMS = 8


def default_workers() -> int:
    """Processes to work in: the CPUs this process may use, at most :data:`MAX_WORKERS` (at least 1)."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, MAX_WORKERS))


def can_fork() -> bool:
    """Whether this process may fork a worker: ``fork`` exists and no other Python thread runs."""
    return hasattr(os, "fork") and threading.active_count() == 1


#: Bytes of an index in the counter's pipe.
_INDEX = 4
#: Most items shared out: their indices must fit in a pipe's buffer (64 kB on Linux) at once.
MAX_ITEMS = 16_384


class _Counter:
    """The items' indices, each given out once, shared by the processes forked after it was made.

    They wait in a pipe, written at once in order; a process takes the next by reading one
    index (a read of a few bytes from a pipe is whole and atomic). Nothing is held between
    two takes, so a process interrupted anywhere leaves the others free to go on.
    """

    def __init__(self, read: int, write: int):
        self._read, self._write = read, write

    @classmethod
    def of(cls, n: int) -> _Counter | None:
        """The counter of ``n`` items, or None when the pipe cannot hold their indices at once."""
        read, write = os.pipe()
        os.set_blocking(read, False)
        os.set_blocking(write, False)
        data = b"".join(i.to_bytes(_INDEX, "little") for i in range(n))
        try:
            written = os.write(write, data)
        except BlockingIOError:
            written = 0
        counter = cls(read, write)
        if written != len(data):  # (a smaller pipe: the system's pipe buffers are scarce)
            counter.close()
            return None
        return counter

    def take(self) -> int | None:
        """The next index, or None when all were taken."""
        try:
            data = os.read(self._read, _INDEX)
        except BlockingIOError:
            return None
        return int.from_bytes(data, "little") if len(data) == _INDEX else None

    def stop(self) -> None:
        """Give out no more indices (the children stop at their next item)."""
        while self.take() is not None:
            pass

    def close(self) -> None:
        """Close this process's ends of the pipe."""
        os.close(self._read)
        os.close(self._write)


def _hold_interrupts() -> set[int | signal.Signals]:
    """Hold SIGINT back from this thread (from now until :func:`_release`); the signals held before."""
    if not hasattr(signal, "pthread_sigmask"):
        return set()
    return signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


def _release(held: set[int | signal.Signals]) -> None:
    """Deliver a SIGINT held back by :func:`_hold_interrupts` (KeyboardInterrupt is raised here)."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def _child(
    fn: Callable[[T], R],
    items: Sequence[T],
    counter: _Counter,
    ship: Callable[[T, R], object],
    out: int,
    held: set[int | signal.Signals],
) -> NoReturn:
    """A forked child's whole life: map the items it takes, send (index, result) pairs, exit (never returns)."""
    gc.disable()  # (a collection would touch, and so copy, every page of objects it shares with its parent)
    try:
        _release(held)  # (a Ctrl-C during the fork ends the child here, quietly)
        done = []
        while (i := counter.take()) is not None:
            done.append((i, ship(items[i], fn(items[i]))))
        data = pickle.dumps(done, protocol=pickle.HIGHEST_PROTOCOL)
        with os.fdopen(out, "wb") as f:
            f.write(data)
    except BaseException:  # (the parent does the items it took itself)
        pass
    finally:
        os._exit(0)


def forked_map(
    fn: Callable[[T], R],
    items: Sequence[T],
    workers: int | None = None,
    ship: Callable[[T, R], object] | None = None,
    land: Callable[[T, object], R] | None = None,
) -> list[R]:
    """``[fn(x) for x in items]``, with forked children taking a share of the items (module docstring).

    The processes take the items one at a time, in order, each the next one when it is free (a
    slow item or a slower process does not hold the others up).

    Args:
        fn: The function; its results must pickle.
        items: The items.
        workers: Processes to work in, this one included (default :func:`default_workers`).
        ship: What a child sends back for an item and its result (default: the result), e.g.
            the result without arrays the parent holds anyway.
        land: The result from what :func:`ship` sent, in the parent (default: as sent).

    Returns:
        The results, in the order of ``items``.
    """
    n = min(default_workers() if workers is None else max(1, workers), len(items))
    if n < 2 or not MIN_ITEMS <= len(items) <= MAX_ITEMS or not can_fork():
        return [fn(x) for x in items]
    counter = _Counter.of(len(items))
    if counter is None:
        return [fn(x) for x in items]
    send = ship if ship is not None else (lambda _x, r: r)
    children: list[tuple[int, int]] = []  # (pid, read end of its pipe)
    try:
        for _ in range(1, n):
            r, w = os.pipe()
            held = _hold_interrupts()  # (a Ctrl-C during the fork would interrupt the child's after-fork hooks)
            try:
                pid = os.fork()
            except BaseException:
                _release(held)
                raise
            if pid == 0:  # the child
                os.close(r)
                _child(fn, items, counter, send, w, held)
            children.append((pid, r))
            os.close(w)
            _release(held)
        results: dict[int, R] = {}
        while (i := counter.take()) is not None:
            results[i] = fn(items[i])
        for _, r in children:
            for i, sent in _received(r):
                results[i] = land(items[i], sent) if land is not None else sent  # type: ignore[assignment]
        # (the items a failed child took, done here)
        return [results[i] if i in results else fn(x) for i, x in enumerate(items)]
    finally:
        counter.stop()  # (after a failure here: the children stop at their next item)
        for pid, r in children:
            try:
                os.close(r)  # (a child still writing gets EPIPE and exits)
            except OSError:
                pass
            os.waitpid(pid, 0)
        counter.close()


def _received(fd: int) -> list[tuple[int, object]]:
    """The (index, what was sent) pairs a child wrote to its pipe; none when it failed."""
    with os.fdopen(os.dup(fd), "rb") as f:
        data = f.read()
    try:
        sent = pickle.loads(data) if data else []
    except Exception:  # (a truncated message: the child died while writing)
        return []
    return sent if isinstance(sent, list) else []
