"""The shared flag parsers and the library-error-to-flag mapping, on good and bad input."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from resus.cli.parsers import (
    flag_error,
    parse_angles,
    parse_choice,
    parse_index_set,
    parse_names,
    parse_numbers,
    parse_range,
    settings_from_flags,
)
from resus.errors import ResusError


def test_numbers():
    assert parse_numbers("0,-0.04", "--start", count=2) == (0.0, -0.04)
    assert parse_numbers("1, 2 ,3", "--x") == (1.0, 2.0, 3.0)
    assert parse_numbers("24,20,16", "--voxels", count=3, kind=int) == (24, 20, 16)
    assert parse_numbers("-1:2", "--range", count=2, separator=":") == (-1.0, 2.0)


@pytest.mark.parametrize(
    ("text", "count", "kind", "message"),
    [
        ("1", 2, float, "--opt: expected 2 comma-separated numbers, got '1'"),
        ("1,2,3", 2, float, "expected 2 comma-separated numbers"),
        ("1,x", None, float, "--opt: expected a list of comma-separated numbers, got '1,x'"),
        ("1,,2", None, float, "expected a list of"),
        ("", None, float, "expected a list of"),
        ("nan,1", 2, float, "expected 2 comma-separated numbers"),
        ("1,inf", 2, float, "expected 2"),
        ("1.5,2,3", 3, int, "--opt: expected 3 comma-separated integers, got '1.5,2,3'"),
    ],
)
def test_bad_numbers_name_the_flag(text, count, kind, message):
    with pytest.raises(ResusError, match=r"^--opt: ") as refused:
        parse_numbers(text, "--opt", count=count, kind=kind)
    assert message in str(refused.value)


def test_index_sets():
    assert parse_index_set("3", "--subjects") == [3]
    assert parse_index_set("0-7", "--subjects") == list(range(8))
    assert parse_index_set("5,0,2", "--subjects") == [0, 2, 5]
    assert parse_index_set("0-2, 2 ,4-4", "--subjects") == [0, 1, 2, 4]


@pytest.mark.parametrize("text", ["", "a", "-1", "3-1", "1-", "0-2-4", "1,,2", "1.5", "+3"])
def test_bad_index_sets_name_the_flag(text):
    with pytest.raises(ResusError, match=r"^--subjects: expected e\.g\. 3, 0-7 or 0,2,5, got "):
        parse_index_set(text, "--subjects")


def test_choices_and_names():
    assert parse_choice("fan", "--pattern", ("linear", "fan")) == "fan"
    with pytest.raises(ResusError, match=r"^--pattern must be one of linear, fan, got 'Fan'$"):
        parse_choice("Fan", "--pattern", ("linear", "fan"))
    regimes = ("us", "imagenet", "aug", "resus")
    assert parse_names("resus, us,resus", "--regimes", regimes) == ["resus", "us"]
    for text in ("", ",", "us,magic"):
        with pytest.raises(ResusError, match=r"^--regimes: expected a comma list of us, imagenet"):
            parse_names(text, "--regimes", regimes)


def test_angles_and_ranges():
    assert parse_angles("-30:30:10") == (-30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0)
    assert parse_angles("0:25:10", "--angles") == (0.0, 10.0, 20.0)
    assert parse_angles("0:0.3:0.1") == pytest.approx((0.0, 0.1, 0.2, 0.3))  # stop kept
    assert parse_angles("7.5") == (7.5,)
    for text, message in (
        ("30:-30:10", "step > 0 and stop >= start"),
        ("0:30:0", "step > 0 and stop >= start"),
        ("1:2", "expected 3 colon-separated numbers"),
        ("a,b", "comma-separated numbers"),
    ):
        with pytest.raises(ResusError, match=r"^--angles: expected") as refused:
            parse_angles(text)
        assert message in str(refused.value)
    assert parse_range("-0.5:0.5", "--range") == (-0.5, 0.5)
    for text in ("0.5:-0.5", "1:1", "1", "a:b", "0:1:2"):
        with pytest.raises(ResusError, match=r"^--range: expected "):
            parse_range(text, "--range")


@dataclass(frozen=True)
class Knobs:
    """A library settings class: it checks its own fields and names them its own way."""

    radius: float = 1.0
    method: str = "sdw"
    low: float = 0.0
    high: float = 1.0

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ResusError(f"Knobs.radius must be positive, got {self.radius}")
        if self.method not in ("sdw", "nn"):
            raise ValueError(f"Knobs.method must be sdw or nn, got {self.method!r}")
        if not self.low < self.high:
            raise ResusError("Knobs.low must be below Knobs.high")


def test_settings_from_flags_reports_the_refused_value_under_its_flag():
    made = settings_from_flags(Knobs, radius=("--radius", 2.0), method=("--method", "nn"))
    assert made == Knobs(radius=2.0, method="nn")
    with pytest.raises(ResusError, match=r"^--radius: Knobs\.radius must be positive, got -1"):
        settings_from_flags(Knobs, method=("--method", "nn"), radius=("--radius", -1.0))
    with pytest.raises(ResusError, match=r"^--method: Knobs\.method must be sdw or nn"):
        settings_from_flags(Knobs, radius=("--radius", 2.0), method=("--method", "cubic"))
    # a combination no single value explains keeps the library's message, in flags
    with pytest.raises(ResusError, match=r"^--low must be below --high$"):
        settings_from_flags(Knobs, low=("--low", 0.8), high=("--high", 0.5))


def test_flag_error_names_the_flag_once():
    with pytest.raises(ResusError, match=r"^--preset: unknown preset 'x'$"), flag_error("--preset"):
        raise ResusError("unknown preset 'x'")
    with pytest.raises(ResusError, match=r"^--fault 'x': bad fault$"), flag_error("--fault"):
        raise ValueError("--fault 'x': bad fault")
    with flag_error("--preset"):
        pass
