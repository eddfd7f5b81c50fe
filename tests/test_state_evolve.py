"""evolve: dataclasses.replace's result, by the fast path where it is safe."""

from __future__ import annotations

import dataclasses
import functools

import pytest

from gantry_sim.controller.gcode.state import ModalState, evolve


def test_a_modal_state_evolves_to_what_replace_gives_and_the_old_one_is_kept() -> None:
    s = ModalState(position=(1.0, 2.0, 3.0), feed_mm_per_min=500.0, plane="XZ")
    new = evolve(s, feed_mm_per_min=900.0, inch=True)
    assert new == dataclasses.replace(s, feed_mm_per_min=900.0, inch=True)
    assert type(new) is ModalState and new is not s
    assert s.feed_mm_per_min == 500.0 and not s.inch
    assert new.scale == dataclasses.replace(s, inch=True).scale


def test_a_name_that_is_no_field_is_refused_as_replace_refuses_it() -> None:
    with pytest.raises(TypeError):
        evolve(ModalState(), fed=3.0)


@dataclasses.dataclass(frozen=True)
class _Checked:
    x: float

    def __post_init__(self) -> None:
        if self.x < 0:
            raise ValueError("x < 0")


@dataclasses.dataclass(frozen=True, slots=True)
class _Slotted:
    x: float


@dataclasses.dataclass(frozen=True)
class _Cached:
    x: float

    @functools.cached_property
    def twice(self) -> float:
        return 2 * self.x


def test_records_with_checks_slots_or_cached_properties_go_through_replace() -> None:
    with pytest.raises(ValueError, match="x < 0"):
        evolve(_Checked(1.0), x=-1.0)
    assert evolve(_Slotted(1.0), x=2.0) == _Slotted(2.0)
    c = _Cached(1.0)
    assert c.twice == 2.0  # cached in the instance's __dict__
    assert evolve(c, x=5.0).twice == 10.0
