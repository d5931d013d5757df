"""Values the loader accepts as numbers but that leave the arm unactuated or unobserved
are refused with the bound that applies (``diagrams.sections``, ``diagrams.scenario``):
too few DAC bits or encoder counts, a gear backlash of a good part of a turn. 0 stays
the documented ideal DAC and encoder."""

from __future__ import annotations

import math
import re

import pytest

import posfb
from posfb.diagrams.scenario import MAX_BACKLASH
from posfb.diagrams.sections import MIN_DAC_BITS, MIN_ENCODER_COUNTS
from posfb.models.design.initial import QUANTISATION_FRACTION, QUARTER_TURN


def test_the_bounds_are_the_arithmetic_their_reasons_state():
    # one count of the fewest counts is at most a quarter turn; one fewer is more
    assert 2 * math.pi / MIN_ENCODER_COUNTS <= QUARTER_TURN < 2 * math.pi / (MIN_ENCODER_COUNTS - 1)
    # one DAC step, 2 / 2^b of the limit, is within the PID rule's share; a bit fewer is not
    assert 2 / 2**MIN_DAC_BITS <= QUANTISATION_FRACTION < 2 / 2 ** (MIN_DAC_BITS - 1)
    assert pytest.approx(2 * math.pi / 64) == MAX_BACKLASH


@pytest.mark.parametrize(
    ("setting", "needle"),
    [
        ("actuator.dac_bits=1", "actuator.dac_bits = 1; 0 (ideal) or at least 6 bits"),
        (f"actuator.dac_bits={MIN_DAC_BITS - 1}", "at least 6 bits"),
        ("sensor.encoder_counts=1", "sensor.encoder_counts[0] = 1; 0 (ideal) or at least 4"),
        ("sensor.encoder_counts=[20000, 3]", "sensor.encoder_counts[1] = 3"),
    ],
)
def test_too_coarse_a_dac_or_encoder_is_refused_with_its_bound(setting, needle):
    with pytest.raises(ValueError, match=re.escape(needle)):
        posfb.load_scenario(None, [setting])


@pytest.mark.parametrize(
    "setting",
    ["actuator.dac_bits=0", f"actuator.dac_bits={MIN_DAC_BITS}", "sensor.encoder_counts=0",
     f"sensor.encoder_counts={MIN_ENCODER_COUNTS}"],
)  # fmt: skip
def test_the_ideal_and_the_coarsest_allowed_values_load(setting):
    posfb.load_scenario(None, [setting])


def test_a_backlash_of_a_good_part_of_a_turn_is_refused_and_a_gears_is_not():
    stiff = "plant.gear_stiffness=1000"
    with pytest.raises(ValueError, match=r"plant.backlash\[1\] = 100 rad; at most 0.0982 rad"):
        posfb.load_scenario(None, [stiff, "plant.backlash=[0.001, 100]"])
    posfb.load_scenario(None, [stiff, f"plant.backlash={MAX_BACKLASH}"])
