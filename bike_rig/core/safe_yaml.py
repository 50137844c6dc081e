"""YAML read within bounded time and memory (size, nesting and alias-expansion caps), no key repeated.

PyYAML's ``SafeLoader`` refuses arbitrary objects but not hostile shapes (deep nesting, a
"billion laughs" of aliases). A document is composed once with its nesting counted, its node
graph measured without recursion, and constructed only within :data:`LIMITS`; a repeated key is
refused (:class:`YamlDuplicateKeyError`). Failures are :class:`YamlLimitError` or
``yaml.YAMLError`` (:func:`yaml_error_reason` gives line and reason).
:func:`read_regular_file` reads only a regular file within a size cap (never a FIFO or device).
"""

from __future__ import annotations

import errno
import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import yaml

from .errors import InputFileError, one_line

__all__ = [
    "LIMITS",
    "NotRegularFileError",
    "YamlDuplicateKeyError",
    "YamlLimitError",
    "YamlLimits",
    "compose_bounded",
    "construct",
    "open_regular_file",
    "read_regular_file",
    "yaml_error_reason",
]


@dataclass(frozen=True)
class YamlLimits:
    """What a YAML document read by bike_rig may hold.

    Attributes:
        max_bytes: The file size [bytes]; ours are a few kB (a measurement file with trial
            lists some tens of kB), and the pure-Python parser reads about 1 MB/s.
        max_depth: Nesting of collections, aliases followed; ours nest at most 6 deep.
        max_nodes: Nodes of the document once every alias is expanded.
    """

    max_bytes: int = 1 << 20
    max_depth: int = 64
    max_nodes: int = 100_000


#: The limits every bike_rig YAML file is read within.
LIMITS = YamlLimits()


class YamlLimitError(ValueError):
    """A YAML document bike_rig refuses: beyond :data:`LIMITS` (too deep, too large once expanded, recursive).

    Attributes:
        reason: Why, in one line.
        line: The 1-based line where it was seen, if known.
    """

    def __init__(self, reason: str, line: int | None = None):
        """Keep the reason and the line."""
        super().__init__(reason)
        self.reason = reason
        self.line = line


class YamlDuplicateKeyError(YamlLimitError):
    """A mapping gives the same key twice (PyYAML would keep the last silently).

    Attributes:
        key: The key's path, dotted (``frame.mass``, ``frame.orientations[0].distance``).
        line: The 1-based line of the repeat.
        first_line: The 1-based line where the key was first given.
    """

    def __init__(self, key: str, line: int, first_line: int):
        """Keep the key and both lines."""
        super().__init__(f"key '{key}' given twice (first on line {first_line})", line)
        self.key = key
        self.first_line = first_line


class _BoundedLoader(yaml.SafeLoader):
    """A ``SafeLoader`` that refuses nesting deeper than ``LIMITS.max_depth`` while composing."""

    def __init__(self, stream: str, limits: YamlLimits):
        super().__init__(stream)
        self._limits = limits
        self._depth = 0

    def compose_node(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        self._depth += 1
        try:
            if self._depth > self._limits.max_depth:
                mark = self.peek_event().start_mark
                raise YamlLimitError(f"nested deeper than {self._limits.max_depth} levels", mark.line + 1)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        try:
            return super().construct_object(node, deep)
        except (ValueError, OverflowError, AttributeError, TypeError) as exc:  # a bad date, a 5,000-digit integer
            if isinstance(exc, YamlLimitError):
                raise
            raise YamlLimitError(f"cannot read the value ({one_line(str(exc))})", node.start_mark.line + 1) from None


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _check_expansion(root: yaml.Node, limits: YamlLimits) -> None:
    """Refuse a node graph that is cyclic, or deeper or larger than ``limits`` once expanded.

    Each distinct node is visited once (iteratively); its expanded size and depth are those of
    its children plus one, so shared (aliased) nodes count as often as they are used.
    """
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    open_: set[int] = set()
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            kids = _children(node)
            size[key] = 1 + sum(size[id(k)] for k in kids)
            depth[key] = 1 + max((depth[id(k)] for k in kids), default=0)
            open_.discard(key)
            if size[key] > limits.max_nodes:
                reason = f"expands to more than {limits.max_nodes} values (through its aliases)"
                raise YamlLimitError(reason, node.start_mark.line + 1)
            if depth[key] > limits.max_depth:
                raise YamlLimitError(
                    f"nested deeper than {limits.max_depth} levels (through its aliases)", node.start_mark.line + 1
                )
            continue
        if key in size:
            continue
        if key in open_:
            raise YamlLimitError("an alias refers to a node that contains it", node.start_mark.line + 1)
        open_.add(key)
        stack.append((node, True))
        stack.extend((k, False) for k in _children(node) if id(k) not in size)


_MERGE_TAG = "tag:yaml.org,2002:merge"


def _key_label(path: tuple[object, ...]) -> str:
    """A key's path as text: ``frame.orientations[0].distance``."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


#: The identity of a key that is not compared (a collection, which safe loading refuses anyway).
_UNCOMPARED = object()


def _key_identity(node: yaml.Node, loader: _BoundedLoader) -> object:
    """The Python key a key node constructs (``1``, ``01`` and ``0x1`` are one), or :data:`_UNCOMPARED`."""
    if not isinstance(node, yaml.ScalarNode):
        return _UNCOMPARED  # safe loading refuses a collection as a key when it constructs the document
    value = loader.construct_object(node)
    try:
        hash(value)
    except TypeError:
        return _UNCOMPARED
    return value  # (keys equal in Python, such as 1 and true, would collapse in the dict: a repeat)


def _check_duplicate_keys(root: yaml.Node, loader: _BoundedLoader) -> None:
    """Refuse a mapping that repeats a key (merge keys ``<<`` aside), naming it and both lines.

    Each distinct node is visited once, without recursion, under the path it is first reached by.
    """
    seen: set[int] = set()
    stack: list[tuple[yaml.Node, tuple[object, ...]]] = [(root, ())]
    while stack:
        node, path = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            stack.extend((item, (*path, i)) for i, item in reversed(list(enumerate(node.value))))
        elif isinstance(node, yaml.MappingNode):
            first: dict[object, int] = {}
            children = []
            for key, value in node.value:
                if key.tag == _MERGE_TAG:
                    continue
                name = key.value if isinstance(key, yaml.ScalarNode) else "?"
                identity = _key_identity(key, loader)
                line = key.start_mark.line + 1
                if identity is not _UNCOMPARED:
                    if identity in first:
                        raise YamlDuplicateKeyError(_key_label((*path, name)), line, first[identity])
                    first[identity] = line
                children.append((value, (*path, name)))
            stack.extend(reversed(children))


def compose_bounded(text: str, limits: YamlLimits = LIMITS) -> tuple[yaml.Node | None, _BoundedLoader]:
    """Compose one YAML document within ``limits``.

    Returns:
        The root node (None for an empty document) and the loader that can construct it.

    Raises:
        YamlDuplicateKeyError: a mapping repeats a key.
        YamlLimitError: the document exceeds ``limits``.
        yaml.YAMLError: the text is not YAML.
    """
    if len(text) > limits.max_bytes:
        raise YamlLimitError(f"{len(text)} characters: larger than {limits.max_bytes} bytes, not a bike_rig YAML file")
    loader = _BoundedLoader(text, limits)
    try:
        node = loader.get_single_node()
    except BaseException:
        loader.dispose()
        raise
    if node is not None:
        try:
            _check_expansion(node, limits)
            _check_duplicate_keys(node, loader)
        except BaseException:
            loader.dispose()
            raise
    return node, loader


def construct(node: yaml.Node | None, loader: _BoundedLoader) -> Any:
    """The Python data of a node composed by :func:`compose_bounded` (plain dicts, lists, scalars).

    Raises:
        YamlLimitError: a scalar cannot be read (an impossible date, an integer too long).
        yaml.YAMLError: a tag or key that safe loading refuses.
    """
    try:
        return None if node is None else loader.construct_document(node)
    finally:
        loader.dispose()


def yaml_error_reason(exc: yaml.YAMLError, text: str) -> tuple[str, int | None]:
    """A YAML error's reason in one line, and its 1-based line (None when unknown).

    Args:
        exc: The error PyYAML raised.
        text: The document's text (to find the line of a reader error's character position).
    """
    if isinstance(exc, yaml.reader.ReaderError):
        line = text.count("\n", 0, max(exc.position, 0)) + 1
        char = exc.character
        code = char if isinstance(char, int) else ord(char[:1] or "\0")
        return f"unacceptable character #x{code:04x} ({exc.reason})", line
    if isinstance(exc, yaml.MarkedYAMLError):
        mark = exc.problem_mark or exc.context_mark
        problem = exc.problem or exc.context or "invalid"
        context = f" ({one_line(exc.context)})" if exc.context and exc.problem else ""
        return one_line(problem) + context, (mark.line + 1 if mark is not None else None)
    return one_line(str(exc)), None


# ---------------------------------------------------------------- the file itself


class NotRegularFileError(InputFileError):
    """The path is not a readable regular file: missing, a FIFO, a device, a directory, a symlink loop.

    Attributes:
        os_error: The error of ``stat`` or ``open`` when the path could not be followed (missing,
            unreadable, a loop), None when it is a file of another kind.
    """

    def __init__(self, path: str, reason: str, os_error: OSError | None = None):
        """Keep the file, the reason and the system's error."""
        super().__init__(path, reason)
        self.os_error = os_error


#: What each kind of special file is called in messages.
_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


def _link_target(path: Path) -> str | None:
    """Where the symlink ``path`` points, or None when it is not a symlink."""
    try:
        return os.readlink(path)
    except OSError:
        return None


def _not_regular(name: str, path: Path, mode: int) -> NotRegularFileError:
    kind = next((what for test, what in _KINDS if test(mode)), "a special file")
    target = _link_target(path)
    through = f" (through a symlink to {target})" if target is not None else ""
    return NotRegularFileError(name, f"is {kind}{through}, not a regular file")


def _stat_error(name: str, path: Path, exc: OSError) -> NotRegularFileError:
    if exc.errno == errno.ELOOP:
        reason = "is a symlink loop (or a chain of more than 40 symlinks), not a file"
    elif exc.errno in (errno.ENOENT, errno.ENOTDIR):
        target = _link_target(path)
        reason = "no such file" + (f" (a broken symlink to {target})" if target else "")
    else:
        reason = f"cannot read ({exc.strerror or exc})"
    return NotRegularFileError(name, reason, exc)


def open_regular_file(name: str, path: str | os.PathLike[str]) -> BinaryIO:
    """Open a regular file for reading in binary; refuse anything else without blocking.

    The path is checked with ``stat`` before it is opened (a device is never opened), and the
    open file again (``O_NONBLOCK``: a FIFO put in its place meanwhile does not block the open).

    Args:
        name: The file as the user gave it, for messages.
        path: The file.

    Raises:
        NotRegularFileError: missing, a FIFO, a device, a socket, a directory, a symlink loop or
            unreadable; the message says which.
    """
    p = Path(path)
    try:
        mode = os.stat(p).st_mode
    except OSError as exc:
        raise _stat_error(name, p, exc) from None
    if not stat.S_ISREG(mode):
        raise _not_regular(name, p, mode)
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(p, flags)
    except OSError as exc:
        raise _stat_error(name, p, exc) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise _not_regular(name, p, mode)
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_regular_file(name: str, path: str | os.PathLike[str], max_bytes: int, what: str) -> bytes:
    """The bytes of a regular file of at most ``max_bytes`` (see :func:`open_regular_file`).

    Args:
        name: The file as the user gave it, for messages.
        path: The file.
        max_bytes: The most bytes it may hold.
        what: What such a file is, for the message of a larger one (``a bike_rig YAML file``).

    Raises:
        NotRegularFileError: not a readable regular file.
        InputFileError: larger than ``max_bytes``, or a read fails.
    """
    with open_regular_file(name, path) as f:
        try:
            size = os.fstat(f.fileno()).st_size
            data = f.read(max_bytes + 1) if size <= max_bytes else b""  # (a file that grew meanwhile is cut)
        except OSError as exc:
            raise InputFileError(name, f"cannot read ({exc.strerror or exc})") from None
    size = max(size, len(data))
    if size > max_bytes:
        raise InputFileError(name, f"{size} bytes: larger than {max_bytes} bytes, not {what}")
    return data
