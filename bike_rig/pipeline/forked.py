"""Offline work shared with forked child processes: the fits of a session on every CPU.

The fit of a trial is Python-bound (about 1,100 numpy and Python calls per trial), so threads
do not run two at once; processes do. :func:`forked_map` maps a function over a list, this
process and n − 1 forked children taking the items one at a time, each the next one when it is
free; each child inherits the items and the function (nothing is pickled on the way in) and
sends its results back through a pipe. The results are the same as a plain map's, bit for bit:
the same code on the same data. (A forked child works slower than its parent at first: every
page it writes that it shares with the parent is copied; taking items as they come keeps both
busy to the end.)

A child is forked only where that is safe and pays: ``fork`` exists, more than one process is
asked for (by default, when this process may use more than one CPU), no other Python thread
runs (forking a multi-threaded process can deadlock the child on a lock another thread held;
threads that Python does not know of, such as OpenBLAS's pool, are not counted: they protect
themselves across a fork), and there are at least :data:`MIN_ITEMS` items (and at most
:data:`MAX_ITEMS`). A child
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
    """Whether this process may fork a worker: ``fork`` exists and no other Python thread runs (module docstring)."""
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
        while self._read >= 0 and self.take() is not None:
            pass

    def close(self) -> None:
        """Close this process's ends of the pipe (once)."""
        ends, self._read, self._write = (self._read, self._write), -1, -1
        for fd in ends:
            if fd >= 0:
                os.close(fd)


_Mask = set[int | signal.Signals]


def _mask() -> _Mask:
    """The signals this thread holds back now."""
    return signal.pthread_sigmask(signal.SIG_BLOCK, ()) if hasattr(signal, "pthread_sigmask") else set()


def _hold_interrupts() -> None:
    """Hold SIGINT back from this thread until the mask is set again (:func:`_set_mask`)."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


def _set_mask(mask: _Mask) -> None:
    """Hold back ``mask`` only: a SIGINT held back meanwhile is delivered (KeyboardInterrupt is raised here)."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _child(
    fn: Callable[[T], R],
    items: Sequence[T],
    counter: _Counter,
    ship: Callable[[T, R], object],
    out: int,
    mask: _Mask,
) -> NoReturn:
    """A forked child's whole life: map the items it takes, send (index, result) pairs, exit (never returns)."""
    gc.disable()  # (a collection would touch, and so copy, every page of objects it shares with its parent)
    try:
        _set_mask(mask)  # (a Ctrl-C during the fork ends the child here, quietly)
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


def _start_child(
    fn: Callable[[T], R],
    items: Sequence[T],
    counter: _Counter,
    ship: Callable[[T, R], object],
    children: list[tuple[int, int]],
) -> bool:
    """Fork one more child and add its (pid, read end of its pipe) to ``children``.

    Returns:
        False when the system gives no pipe or no process (nothing is left open).
    """
    mask = _mask()
    try:
        _hold_interrupts()  # (a Ctrl-C during the fork would interrupt the child's after-fork hooks)
        try:
            r, w = os.pipe()
        except OSError:
            return False
        try:
            pid = os.fork()
        except OSError:
            os.close(r)
            os.close(w)
            return False
        if pid == 0:  # the child: only its own pipe's write end (the others' readers must see them end)
            os.close(r)
            for _, earlier in children:
                os.close(earlier)
            _child(fn, items, counter, ship, w, mask)
        children.append((pid, r))
        os.close(w)
        return True
    finally:
        _set_mask(mask)  # (in this process: a Ctrl-C held back is raised now, the child already listed)


def _reap(children: list[tuple[int, int]], counter: _Counter) -> None:
    """Stop the children and wait for each; a Ctrl-C meanwhile is raised once they are gone."""
    reads = [r for _, r in children]
    pids = [pid for pid, _ in children]
    interrupted: KeyboardInterrupt | None = None
    while True:
        try:
            counter.stop()  # (the children stop at their next item)
            while reads:
                os.close(reads.pop())  # (a child still writing gets EPIPE and exits)
            while pids:
                try:
                    os.waitpid(pids[-1], 0)
                except ChildProcessError:
                    pass  # (reaped already, before an interruption)
                pids.pop()
            counter.close()
            break
        except KeyboardInterrupt as exc:
            interrupted = exc
    if interrupted is not None:
        raise interrupted


def forked_map(
    fn: Callable[[T], R],
    items: Sequence[T],
    workers: int | None = None,
    ship: Callable[[T, R], object] | None = None,
    land: Callable[[T, object], R] | None = None,
) -> list[R]:
    """``[fn(x) for x in items]``, with forked children taking a share of the items (module docstring).

    The processes take the items one at a time, in order, each the next one when it is free (a
    slow item or a slower process does not hold the others up). When the system gives fewer
    processes than asked for, the work is shared among those it gave.

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
    try:
        counter = _Counter.of(len(items))
    except OSError:  # (no pipe to be had)
        counter = None
    if counter is None:
        return [fn(x) for x in items]
    send = ship if ship is not None else (lambda _x, r: r)
    children: list[tuple[int, int]] = []  # (pid, read end of its pipe)
    try:
        while len(children) < n - 1 and _start_child(fn, items, counter, send, children):
            pass
        results: dict[int, R] = {}
        while (i := counter.take()) is not None:
            results[i] = fn(items[i])
        for _, r in children:
            for i, sent in _received(r):
                results[i] = land(items[i], sent) if land is not None else sent  # type: ignore[assignment]
        # (the items a failed child took, done here)
        return [results[i] if i in results else fn(x) for i, x in enumerate(items)]
    finally:
        _reap(children, counter)


def _received(fd: int) -> list[tuple[int, object]]:
    """The (index, what was sent) pairs a child wrote to its pipe; none when it failed."""
    with os.fdopen(os.dup(fd), "rb") as f:
        data = f.read()
    try:
        sent = pickle.loads(data) if data else []
    except Exception:  # (a truncated message: the child died while writing)
        return []
    return sent if isinstance(sent, list) else []
