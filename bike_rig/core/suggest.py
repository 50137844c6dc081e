"""A "did you mean" for a mistyped word: the closest of the valid choices (difflib), if any is close."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["did_you_mean"]


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the choice closest to ``word``; "" when none is close.

    Args:
        word: What was typed.
        choices: The valid words.
    """
    found = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{found[0]}'?)" if found else ""
