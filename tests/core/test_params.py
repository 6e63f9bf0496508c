"""Param: one declaration and one check for every block, attacker and scene parameter."""
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carav_stream.core.params import REQUIRED, Param, problems, resolved, suggest

ETA = Param("eta", float, 1.5, "threshold", low=0.0, strict=True, unit="1")
MODEL = Param("model", str, "none", "attack model", choices=("none", "random", "smart"))
COUNT = Param("n", int, REQUIRED, "count", low=1, high=10)
SEED = Param("seed", int, None, "simulation seed", optional=True, graph_wide=True)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nan_and_infinity_are_refused_wherever_a_float_is_declared(bad):
    assert ETA.check(bad)[1] == f"must be a finite number, got {bad!r}"
    assert Param("x", float, 0.0).check(bad)[1] is not None           # with no bounds too


def test_ints_widen_to_floats_but_bools_are_not_numbers_and_strings_not_ints():
    assert ETA.check(2) == (2.0, None) and isinstance(ETA.check(2)[0], float)
    assert ETA.check(True)[1] == "must be float, got bool True"
    assert COUNT.check("3")[1] == "must be int, got str '3'"
    assert COUNT.check(3.0)[1] == "must be int, got float 3.0"


def test_bounds_choices_and_optional_values():
    assert ETA.check(0.0)[1] == "must be > 0, got 0"
    assert ETA.check(-1.5)[1] == "must be > 0, got -1.5"
    assert COUNT.check(11)[1] == "must be <= 10, got 11" and COUNT.check(10) == (10, None)
    assert MODEL.check("smrt")[1] == "must be one of ['none', 'random', 'smart'], got 'smrt'"
    assert SEED.check(None) == (None, None) and COUNT.check(None)[1] is not None


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_a_finite_float_passes_exactly_when_it_is_inside_the_bounds(x):
    p = Param("x", float, 0.0, low=-1.0, high=1.0, strict=True)
    assert (p.check(x)[1] is None) == (-1.0 < x < 1.0)


def test_problems_name_every_parameter_and_suggest_close_names():
    found = dict(problems([ETA, MODEL, COUNT], {"etta": 2.0, "model": "smart"}, owner="rms_detector"))
    assert found == {"etta": "unknown parameter for rms_detector (did you mean 'eta'?)",
                     "n": "missing required parameter (count)"}
    assert suggest("zzz", ["a", "b"]) == " (known: a, b)"
    assert resolved([ETA, MODEL], {"eta": 2}) == {"eta": 2.0, "model": "none"}


def test_describe_gives_type_default_meaning_unit_and_range_on_one_line():
    assert ETA.describe().split() == ["float", "=", "1.5", "threshold", "[1]", "(>", "0)"]
    assert "one of ['none', 'random', 'smart']" in MODEL.describe()
    assert "(required)" in COUNT.describe() and "(>= 1, <= 10)" in COUNT.describe()
    assert SEED.describe().endswith("(graph-wide)")
