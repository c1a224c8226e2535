"""A scenario's choice of arm: one source, tables of one length, each arm ready for the cell
with the names, limits and speeds it was given."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from cell.errors import InputError
from cell.robots.choice import ArmChoice, ArmsParams, cell_arm
from cell.robots.dh import KUKA_LWR4, VIPER_S1700D
from tests.robotarms import UR5E, write_seven_axis


def test_the_default_arms_are_the_cells_own() -> None:
    arms = ArmsParams().cell_arms()
    assert [(prefix, arm.name, arm.dof) for prefix, arm in arms.items()] == [
        ("knife_arm", VIPER_S1700D.name, 6), ("pull_arm", VIPER_S1700D.name, 6),
        ("camera_arm", KUKA_LWR4.name, 7)]
    assert arms["knife_arm"].description is VIPER_S1700D


@pytest.mark.parametrize(("changes", "field"), [
    ({"builtin": "viper_s1700d"}, "builtin"),           # a DH table and a built-in
    ({"d_m": (0.1,) * 5}, "d_m"),                       # one length short
    ({"max_speed_rad_s": (-1.0,) * 6}, "max_speed_rad_s"),
    ({"lower_rad": (1.0,) * 6, "upper_rad": (0.5,) * 6}, "lower_rad"),
])
def test_a_bad_choice_is_refused_naming_its_key(changes: dict, field: str) -> None:
    with pytest.raises(InputError) as refused:
        replace(UR5E, **changes)
    assert refused.value.field == field


def test_an_unknown_builtin_is_refused() -> None:
    with pytest.raises(InputError, match="viper_s1700d"):
        ArmChoice(builtin="ur10")


def test_a_dh_table_becomes_an_arm_with_its_limits() -> None:
    arm = cell_arm(UR5E)
    assert (arm.name, arm.source, arm.dof) == ("ur5e", "DH table", 6)
    assert arm.max_speed_rad_s == (math.pi,) * 6
    assert arm.spec().compile().nu == 6


def test_a_file_without_rated_speeds_needs_them(tmp_path: Path) -> None:
    path = write_seven_axis(tmp_path)
    with pytest.raises(InputError) as refused:
        cell_arm(ArmChoice(file=str(path)))
    assert refused.value.field == "max_speed_rad_s"
    speeds = (1.0,) * 7
    assert cell_arm(ArmChoice(file=str(path), max_speed_rad_s=speeds)).max_speed_rad_s == speeds


@pytest.mark.parametrize(("choice", "field"), [
    ({"builtin": "viper_s1700d", "max_speed_rad_s": (1.0,) * 6}, "max_speed_rad_s"),
    ({"file": "arm.urdf", "link_masses_kg": (1.0,) * 6}, "link_masses_kg"),
])
def test_what_the_source_has_is_not_given_again(choice: dict, field: str) -> None:
    with pytest.raises(InputError, match="has its own") as refused:
        ArmChoice(**choice)
    assert refused.value.field == field
