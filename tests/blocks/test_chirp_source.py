"""Chirp source: balanced sequences, frames of `batch` cycles, and fresh streams for every block instance."""
import numpy as np
import pytest

from carav_blocks.attacker import AttackerBlock
from carav_blocks.channel import Channel
from carav_blocks.chirp_source import ChirpSource
from carav_stream.radar.streams import seed_streams
from carav_stream.runtime import Frame
from tests.blocks.helpers import SCENE, wire


def test_a_restarted_or_swapped_in_seeded_block_draws_fresh_streams_never_a_replay():
    """Block.instance (incarnation, generation) (0, 0) draws the library's streams; any other instance of the same
    seed draws independent ones, in the source, the channel and the attacker alike."""
    def draws(instance):
        src, ch, att = (ChirpSource(scene=SCENE, seed=9, batch=4), Channel(scene=SCENE, seed=9),
                        AttackerBlock(scene=SCENE, seed=9, model="random", rarms=2.0))
        for b in (src, ch, att):
            b.instance = instance
            b.start()
        src.cycle_budget = None
        rho = src.generate(0)["tx"].payload.copy()
        same = Frame.of(np.arange(256).reshape(4, 64) % 3 == 0, cycle=0, cycles=4)   # one input for every instance
        rx = ch.process(wire(same, 0))
        attack = att.process(wire(rx["air"], 0))
        return rho, rx["rx"].payload.copy(), attack.payload.copy()

    first = draws((0, 0))
    lib = seed_streams(9)
    np.testing.assert_array_equal(first[0], lib.activation.next(4, 64))     # instance (0, 0) is the library's
    for other in ((1, 0), (0, 1), (2, 3)):
        again = draws(other)
        for a, b in zip(first, again):
            assert not np.array_equal(a, b), other
    for a, b in zip(draws((1, 0)), draws((1, 0))):                           # and still reproducible
        np.testing.assert_array_equal(a, b)


class _Clock:
    """A stand-in for the time module: monotonic() reads `now`, which the test moves."""

    def __init__(self):
        self.now = 100.0

    def monotonic(self):
        return self.now


def test_a_paced_source_releases_at_most_cycles_per_s_and_never_catches_up_after_a_stall(monkeypatch):
    import carav_blocks.chirp_source as module
    clock = _Clock()
    monkeypatch.setattr(module, "time", clock)
    src = ChirpSource(scene=SCENE, seed=9, batch=4, cycles_per_s=100.0)
    src.start()
    src.cycle_budget = None
    assert src.ready_in(0) == 0.0                       # the first frame at once
    src.generate(0)
    assert src.ready_in(1) == pytest.approx(0.04)       # 4 cycles at 100 a second
    clock.now += 0.01
    assert src.ready_in(1) == pytest.approx(0.03)
    clock.now += 0.03
    assert src.ready_in(1) == pytest.approx(0.0)
    src.generate(1)
    clock.now += 5.0                                    # a stall downstream: the source waited 5 s
    assert src.ready_in(2) == 0.0
    src.generate(2)
    assert src.ready_in(3) == pytest.approx(0.04)       # no burst to make up for the stall
    unpaced = ChirpSource(scene=SCENE, seed=9, batch=4)
    unpaced.start()
    assert unpaced.ready_in(0) == 0.0
