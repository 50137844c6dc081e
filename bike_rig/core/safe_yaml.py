"""YAML read within bounded time and memory: a size cap, a nesting cap and an alias-expansion cap.

PyYAML's ``SafeLoader`` refuses arbitrary objects but not hostile shapes: a document nested a
few thousand levels deep ends in a ``RecursionError``, and a few hundred bytes of nested aliases
(a "billion laughs" document) expand to millions of nodes for whoever walks the result. Here a
document is composed once with its nesting counted, its node graph is measured without
recursion (as the tree the aliases expand to), and only a document within :data:`LIMITS` is
constructed. Every failure is a :class:`YamlLimitError` or a ``yaml.YAMLError`` whose one-line
reason and line :func:`yaml_error_reason` gives.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import yaml

from .errors import one_line

__all__ = ["LIMITS", "YamlLimitError", "YamlLimits", "compose_bounded", "construct", "yaml_error_reason"]


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
    """A YAML document exceeds :data:`LIMITS` (too deep, too large once expanded, or recursive).

    Attributes:
        reason: Why, in one line.
        line: The 1-based line where it was seen, if known.
    """

    def __init__(self, reason: str, line: int | None = None):
        """Keep the reason and the line."""
        super().__init__(reason)
        self.reason = reason
        self.line = line


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
                raise YamlLimitError(f"nested deeper than {limits.max_depth} levels (through its aliases)",
                                     node.start_mark.line + 1)
            continue
        if key in size:
            continue
        if key in open_:
            raise YamlLimitError("an alias refers to a node that contains it", node.start_mark.line + 1)
        open_.add(key)
        stack.append((node, True))
        stack.extend((k, False) for k in _children(node) if id(k) not in size)


def compose_bounded(text: str, limits: YamlLimits = LIMITS) -> tuple[yaml.Node | None, _BoundedLoader]:
    """Compose one YAML document within ``limits``.

    Returns:
        The root node (None for an empty document) and the loader that can construct it.

    Raises:
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
        _check_expansion(node, limits)
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
