"""Settings that take one value or a comma list (conditions cycled over trials): one reader, one wording."""

from __future__ import annotations

import pytest

from neuronav.errors import ConfigError
from neuronav.scenarios.settings import choice_list, number_list


def test_choice_list_reads_one_or_several_and_names_what_it_takes():
    assert choice_list("legs", "stilts", ("normal", "stilts", "stumps")) == ("stilts",)
    legs = ("normal", "stilts", "stumps")
    assert choice_list("legs", "normal, stumps,normal", legs) == ("normal", "stumps", "normal")
    with pytest.raises(ConfigError, match=r"^legs: expected normal, stilts or stumps, or a comma list of them, "
                                          r"got 'normal,moon'$"):
        choice_list("legs", "normal,moon", ("normal", "stilts", "stumps"))
    with pytest.raises(ConfigError, match="without repeats"):
        choice_list("gait", "tripod,tripod", ("tripod", "wave"), repeats=False)
    assert choice_list("gait", "tripod,wave", ("tripod", "wave"), repeats=False) == ("tripod", "wave")


def test_number_list_reads_numbers_within_their_range():
    assert number_list("conflict_deg", "0, 90,180", 0.0, 180.0, "degrees", "angle") == (0.0, 90.0, 180.0)
    with pytest.raises(ConfigError, match="every angle must be within 0–180 degrees"):
        number_list("conflict_deg", "190", 0.0, 180.0, "degrees", "angle")
    with pytest.raises(ConfigError, match="every offset must be within -10 to 10 m"):
        number_list("release_offset_m", "nan", -10.0, 10.0, "m", "offset")
    with pytest.raises(ConfigError, match=r"release_offset_m: expected an offset or a comma list"):
        number_list("release_offset_m", "1,x", -10.0, 10.0, "m", "offset")
