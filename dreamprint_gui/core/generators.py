"""Running the product's progress generators: :func:`drain` and :func:`relay`.

A job, a proof or a compensation is a generator that yields progress and returns its result
(``StopIteration.value``); these are the two ways its callers consume one.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from typing import Any, TypeVar

__all__ = ["drain", "relay"]

P = TypeVar("P")
Q = TypeVar("Q")
R = TypeVar("R")


def drain(gen: Generator[Any, Any, R]) -> R:
    """Run ``gen`` to its end, its progress discarded; its return value."""
    while True:
        try:
            next(gen)
        except StopIteration as stop:
            return stop.value


def relay(gen: Generator[P, Any, R], convert: Callable[[P], Q]) -> Generator[Q, None, R]:
    """Yield ``convert(p)`` for each progress ``p`` of ``gen`` and return its return value
    (``result = yield from relay(gen, f)``); ``gen`` is closed however this ends."""
    try:
        while True:
            try:
                p = next(gen)
            except StopIteration as stop:
                return stop.value
            yield convert(p)
    finally:
        gen.close()
