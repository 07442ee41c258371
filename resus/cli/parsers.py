"""Flag values to library values, for every command: numbers, index sets, names, angles.

Each parser takes the flag's text and the flag's name and raises a one-line `ResusError`
that names the flag. `settings_from_flags` and `flag_error` do the reverse mapping: the
library checks its own settings and names them; the user still sees the flag they typed.
"""

from __future__ import annotations

import contextlib
import math
import re
from collections.abc import Callable, Collection, Iterator
from typing import TypeVar, overload

from resus.errors import ResusError

T = TypeVar("T")

SEPARATOR_NAMES = {",": "comma", ":": "colon"}


@overload
def parse_numbers(
    text: str, option: str, count: int | None = None, *, kind: type[int], separator: str = ","
) -> tuple[int, ...]: ...


@overload
def parse_numbers(
    text: str,
    option: str,
    count: int | None = None,
    kind: type[float] = float,
    separator: str = ",",
) -> tuple[float, ...]: ...


def parse_numbers(
    text: str,
    option: str,
    count: int | None = None,
    kind: type[int] | type[float] = float,
    separator: str = ",",
) -> tuple[int, ...] | tuple[float, ...]:
    """'a,b,c' -> finite numbers of `kind` (exactly `count` of them when given)."""
    try:
        values = tuple(kind(part) for part in text.split(separator))
    except ValueError:
        values = ()
    wrong_count = count is not None and len(values) != count
    if not values or wrong_count or not all(math.isfinite(value) for value in values):
        amount = "a list of" if count is None else str(count)
        noun = "integers" if kind is int else "numbers"
        raise ResusError(
            f"{option}: expected {amount} {SEPARATOR_NAMES[separator]}-separated {noun}, "
            f"got {text!r}"
        )
    return values


def parse_index_set(text: str, option: str) -> list[int]:
    """'3', '0-7' or '0,2,5' (or a mix, '0-2,5') -> the sorted distinct indices."""
    indices: set[int] = set()
    for part in text.split(","):
        low, dash, high = (piece.strip() for piece in part.partition("-"))
        high = high if dash else low
        if not (low.isdecimal() and high.isdecimal() and int(low) <= int(high)):
            raise ResusError(f"{option}: expected e.g. 3, 0-7 or 0,2,5, got {text!r}")
        indices.update(range(int(low), int(high) + 1))
    return sorted(indices)


def parse_choice(text: str, option: str, allowed: Collection[str]) -> str:
    """`text` when it is one of `allowed`."""
    if text not in allowed:
        raise ResusError(f"{option} must be one of {', '.join(allowed)}, got {text!r}")
    return text


def parse_names(text: str, option: str, allowed: Collection[str]) -> list[str]:
    """'a,b,a' -> ['a', 'b']: a comma list of `allowed` names, first occurrences in order."""
    names = [part.strip() for part in text.split(",") if part.strip()]
    if not names or any(name not in allowed for name in names):
        raise ResusError(f"{option}: expected a comma list of {', '.join(allowed)}, got {text!r}")
    return list(dict.fromkeys(names))


def parse_angles(text: str, option: str = "--angles") -> tuple[float, ...]:
    """'start:stop:step' (degrees, stop included) or a comma list 'a,b,c' -> the angles."""
    if ":" not in text:
        return parse_numbers(text, option)
    start, stop, step = parse_numbers(text, option, count=3, separator=":")
    if not (step > 0 and stop >= start):
        raise ResusError(
            f"{option}: expected start:stop:step with step > 0 and stop >= start, got {text!r}"
        )
    count = math.floor((stop - start) / step + 1e-9) + 1
    return tuple(start + step * k for k in range(count))


def parse_range(text: str, option: str) -> tuple[float, float]:
    """'LOW:HIGH' -> (low, high) with low < high."""
    low, high = parse_numbers(text, option, count=2, separator=":")
    if not low < high:
        raise ResusError(f"{option}: expected LOW:HIGH with LOW < HIGH, got {text!r}")
    return low, high


def _naming(error: Exception, option: str) -> ResusError:
    """`error` as a ResusError about `option` (named once: kept as is if it names it)."""
    message = str(error)
    return ResusError(message if option in message else f"{option}: {message}")


@contextlib.contextmanager
def flag_error(option: str) -> Iterator[None]:
    """Report a ResusError or ValueError raised inside as one about `option`."""
    try:
        yield
    except (ResusError, ValueError) as error:
        raise _naming(error, option) from None


def settings_from_flags(make: Callable[..., T], **flags: tuple[str, object]) -> T:
    """`make(field=value, ...)` from `field=(flag, value)` pairs; a refused value is reported
    under its flag.

    Which value was refused is found by passing each alone (the others at `make`'s defaults),
    so the check stays in the library, in one place. A refused combination of values keeps
    the library's message, with each setting it names as `Settings.field` put as its flag.
    """
    try:
        return make(**{field: value for field, (_, value) in flags.items()})
    except (ResusError, ValueError) as error:
        for field, (option, value) in flags.items():
            with flag_error(option):
                make(**{field: value})
        message = str(error)
        for field, (option, _) in flags.items():
            message = re.sub(rf"\b[A-Z]\w*\.{field}\b", option, message)
        raise ResusError(message) from None
