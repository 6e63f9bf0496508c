"""Channel: echoes plus noise for the transmitted chirps, and the emission the attacker may hear, one cycle late."""
import numpy as np
import pytest

from carav_blocks.channel import Channel
from carav_stream.runtime import Frame
from tests.blocks.helpers import N_S, RHO, SCENE, wire


def test_the_air_port_carries_each_cycles_previous_emission_across_frames():
    ch = Channel(scene=SCENE, seed=3)
    ch.start()
    rho = np.array([RHO, ~RHO, RHO])
    out1 = ch.process(wire(Frame.of(rho[:2], cycle=0, cycles=2), 0))
    out2 = ch.process(wire(Frame.of(rho[2:], cycle=2, cycles=1), 1))
    heard = np.concatenate([out1["air"].payload, out2["air"].payload])
    assert not heard[0].any() and (heard[1:] == rho[:2]).all()        # nothing before cycle 0, then cycle k-1
    assert out1["rx"].payload.shape == (2, 64, N_S) and (out1["rx"].arrays["on_air"] == rho[:2]).all()


def test_silent_chirps_carry_noise_only_and_active_chirps_the_echo_too():
    ch = Channel(scene=SCENE, seed=5)
    ch.start()
    rx = ch.process(wire(Frame.of(RHO[None], cycle=0, cycles=1), 0))["rx"].payload[0]
    power = np.mean(rx.astype(np.float64) ** 2, axis=1)
    assert power[RHO].mean() > 1.2 * power[~RHO].mean()                # the echo adds power where chirps were sent


def test_a_tx_frame_of_the_wrong_shape_is_refused_naming_it():
    ch = Channel(scene=SCENE, seed=1)
    ch.start()
    with pytest.raises(ValueError, match=r"tx frame seq 4: expected \(cycles, 64\) chirps"):
        ch.process(wire(Frame.of(np.zeros((2, 32), bool), cycles=2), 4))
