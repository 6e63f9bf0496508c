"""The "none" model sends nothing: no all-zero attack signal is built, carried between nodes or added at the ADC."""
import numpy as np
import pytest

from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of


@pytest.mark.parametrize("preset", ["table1", "awr1642"])
@pytest.mark.parametrize("compact", [False, True])
def test_the_none_model_is_silent_in_every_cycle(preset, compact):
    attacker = make_attacker("none", scene_of(preset))
    a, active = attacker.emit(8, 0, np.random.default_rng(1), None, compact=compact)
    assert a is None
    assert active.dtype == np.bool_ and active.shape == (8,) and not active.any()
    assert not attacker.on_cycles(8, 1000).any()


def test_the_none_model_leaves_the_received_signal_as_it_is():
    attacker = make_attacker("none", scene_of("table1"))
    rx = np.random.default_rng(2).standard_normal((2, 64, 1080)).astype(np.float32)
    out, active = attacker.apply(rx.copy(), 0, None)
    assert np.array_equal(out, rx) and not active.any()
