"""Mutations of valid files: byte flips, truncations, duplications, deletions, splices and tokens.

:func:`mutate` applies one to four of them, drawn from a seeded :class:`random.Random`, so an
input is reproduced from the campaign's seed and its index.
"""

from __future__ import annotations

import random
import re
from collections.abc import Callable, Sequence

__all__ = ["NUMBER_TOKENS", "YAML_TOKENS", "mutate"]

#: Numbers that break arithmetic: huge, tiny, signed zero, not a number, long digit strings.
NUMBER_TOKENS: tuple[bytes, ...] = (
    b"1e308",
    b"-1e308",
    b"1.7976931348623157e308",
    b"5e-324",
    b"-0.0",
    b"nan",
    b"inf",
    b"-inf",
    b"1e999",
    b"0",
    b"-1",
    b"99999999999999999999999",
    b"1" * 5000,
    b"0x10",
    b"1_000",
)
#: YAML syntax that reaches the loader's corners: anchors, aliases, merges, tags, nesting.
YAML_TOKENS: tuple[bytes, ...] = (
    b"&a ",
    b"*a",
    b"<<: *a",
    b"[",
    b"]",
    b"{",
    b"}",
    b"? ",
    b": ",
    b"- ",
    b"!!binary ",
    b"!!python/tuple ",
    b"!!timestamp ",
    b"!!float ",
    b"!!set ",
    b"|\n",
    b">-\n",
    b"'",
    b'"',
    b"\t",
    b"\x00",
    b"\xef\xbb\xbf",
    b"---\n",
    b"...\n",
    b"%YAML 1.1\n",
    b"#",
    b"\\",
    b"~",
    b".inf",
    b".nan",
    b"yes",
    b"2001-13-45",
    b"[[[[[[[[[[[[[[[[",
    b"+/-",
    b"+/- -",
    b"=",
    b",",
)
_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def _flip(data: bytes, rng: random.Random, _seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        if out:
            out[rng.randrange(len(out))] ^= 1 << rng.randrange(8)
    return bytes(out)


def _byte(data: bytes, rng: random.Random, _seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    if not data:
        return data
    i = rng.randrange(len(data))
    return data[:i] + bytes([rng.choice(b"\x00\xff\n :[{&*-9e.,#\x7f")]) + data[i + 1 :]


def _truncate(data: bytes, rng: random.Random, _seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    return data[: rng.randrange(len(data) + 1)]


def _duplicate(data: bytes, rng: random.Random, _seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    if not data:
        return data
    i = rng.randrange(len(data))
    j = min(len(data), i + rng.randint(1, 512))
    k = rng.randrange(len(data) + 1)
    return data[:k] + data[i:j] * rng.randint(1, 4) + data[k:]


def _delete(data: bytes, rng: random.Random, _seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    if not data:
        return data
    i = rng.randrange(len(data))
    return data[:i] + data[i + rng.randint(1, 256) :]


def _splice(data: bytes, rng: random.Random, seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    other = rng.choice(seeds)
    return data[: rng.randrange(len(data) + 1)] + other[rng.randrange(len(other) + 1) :]


def _token(data: bytes, rng: random.Random, _seeds: Sequence[bytes], tokens: Sequence[bytes]) -> bytes:
    k = rng.randrange(len(data) + 1)
    return data[:k] + rng.choice([*tokens, *NUMBER_TOKENS]) + data[k:]


def _number(data: bytes, rng: random.Random, _seeds: Sequence[bytes], _tokens: Sequence[bytes]) -> bytes:
    found = list(_NUMBER.finditer(data[:200_000]))
    if not found:
        return data
    m = rng.choice(found)
    return data[: m.start()] + rng.choice(NUMBER_TOKENS) + data[m.end() :]


_MUTATORS: tuple[Callable[[bytes, random.Random, Sequence[bytes], Sequence[bytes]], bytes], ...] = (
    _flip,
    _byte,
    _truncate,
    _duplicate,
    _delete,
    _splice,
    _token,
    _number,
    _number,
)


def mutate(data: bytes, rng: random.Random, seeds: Sequence[bytes], tokens: Sequence[bytes] = ()) -> bytes:
    """``data`` changed by one to four mutations drawn from ``rng``.

    Args:
        data: A valid file's bytes.
        rng: The campaign's generator (its state decides the mutations).
        seeds: Valid files to splice from.
        tokens: Format-specific fragments to insert (numbers are always among them).
    """
    for _ in range(rng.randint(1, 4)):
        data = rng.choice(_MUTATORS)(data, rng, seeds, tokens)
    return data
