"""Attacker block: parameters checked by model, the reactive repeater gated at the receiver bit for bit, the pull-off
as the library emits it."""
import numpy as np
import pytest

from carav_blocks.attacker import AttackerBlock
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of
from carav_stream.runtime import BlockError, Frame
from carav_stream.testing.harness import wire
from tests.blocks.helpers import SCENE, front_end


def test_attacker_parameters_are_checked_by_model_with_names():
    with pytest.raises(BlockError, match="unknown parameter for attacker 'random'"):
        AttackerBlock(scene=SCENE, model="random", range_m=30.0)
    with pytest.raises(BlockError, match='fidelity = "waveform"'):
        AttackerBlock(scene=SCENE, model="secondary_antenna")
    with pytest.raises(BlockError, match="must be one of"):
        AttackerBlock(scene=SCENE, model="reactiv")
    with pytest.raises(BlockError, match="unknown parameter for attacker 'reactive'"):
        AttackerBlock(scene=SCENE, model="reactive", range_m=30.0)
    reactive = AttackerBlock(scene=SCENE, model="reactive", distance_m=20.0, latency_s=0.0)
    assert reactive.model_params == {"distance_m": 20.0, "latency_s": 0.0}
    assert AttackerBlock(scene=SCENE, model="smart", rarms=2).model_params == {"rarms": 2.0}



@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_reactive_attack_gated_at_the_receiver_equals_the_library_bit_for_bit(fidelity):
    from carav_stream.radar.attackers import make_attacker
    from carav_stream.radar.streams import scene_of, seed_streams
    from carav_stream.radar.synth import simulate_cycles
    scene, params = scene_of("table1"), {"rarms": 3.0, "start_cycle": 5, "n_active_cycles": 14}
    run = front_end(fidelity, model="reactive", **params)
    streams, lib_streams = seed_streams(4), seed_streams(4)
    lib_attacker, reported = make_attacker("reactive", scene, **params), []
    for seq, cycle0 in enumerate(range(0, 32, 8)):
        rho = streams.activation.next(8, scene.n_chirps)
        rho[1] = rho[2] = False        # never with a Manchester source: an all-silent cycle, before and while on
        rx, air, attack, frames = run(rho, cycle0, seq)
        lib = simulate_cycles(scene, rho, lib_streams.noise, attacker=lib_attacker, rng_attack=lib_streams.attack,
                              fidelity=fidelity, cycle0=cycle0)
        assert frames.payload.tobytes() == lib.codes.tobytes()
        assert frames.header["per_cycle"]["attack_active"] == lib.attack_active.tolist()
        reported += frames.header["per_cycle"]["attack_active"]
        assert frames.header["per_cycle"]["clipped"] == lib.clipped.tolist()
        np.testing.assert_array_equal(rx.arrays["on_air"], rho)                 # the receiver's view
        assert list(air.arrays) == ["data"] and air.header["air_cycle"] == cycle0 - 1   # the attacker's: unchanged
        on = [5 <= c < 19 for c in range(cycle0, cycle0 + 8)]
        assert attack.header["gate_by_on_air"] is True and attack.header["per_cycle"]["attack_active"] == on
        if any(on):   # its replies to every chirp, once for all cycles (broadcast by the receiver)
            assert attack.payload.shape == (1, scene.n_chirps, scene.n_samples)
            assert sorted(attack.arrays) == (["data", "tail"] if fidelity == "waveform" else ["data"])
        else:
            assert attack.payload is None and not attack.arrays
    # on in cycles 5..18, but it answers nothing in the silent cycles 9, 10, 17 and 18
    assert reported == [5 <= c < 19 and c % 8 not in (1, 2) for c in range(32)]


def test_the_pull_off_model_runs_in_the_node_as_the_library_emits_it():
    """The block builds any model of the registry by name (a swap's `--set model=pull_off` too): frame by frame it
    sends what the model's own emit gives for the same cycles, capture then drag."""
    params = {"capture_cycles": 3, "pull_mps": 30.0, "pull_accel_mps2": 3e4, "rarms": 3.0}
    block = AttackerBlock(scene=SCENE, model="pull_off", **params)
    block.start()
    rho = np.zeros((4, 64), bool)
    sent = [wire(block.process(wire(Frame.of(rho[:2], cycle=c0, cycles=2), seq)), seq) for seq, c0 in ((0, 0), (1, 2))]
    model = make_attacker("pull_off", scene_of(SCENE), **params)
    want, active = model.emit(4, 0, None, compact=True)
    np.testing.assert_array_equal(np.concatenate([f.payload for f in sent]), want)
    assert [a for f in sent for a in f.header["per_cycle"]["attack_active"]] == active.tolist() == [True] * 4
    assert model.offset(3) == (0.0, 0.0) and model.offset(4)[0] > 0
