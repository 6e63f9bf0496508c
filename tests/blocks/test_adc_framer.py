"""adc_framer against golden vectors written from the ADC's description, and its refusals."""
import numpy as np
import pytest

from carav_blocks.adc_framer import AdcFramer
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime.frames import Frame
from tests.blocks import jig
from tests.blocks.helpers import N_S, RHO, SCENE, front_end, wire

VECTORS = jig.vectors("adc_framer")


def extract(out: dict[str, Frame], n: int) -> dict[str, np.ndarray]:
    frames = out["frames"]
    per = frames.header["per_cycle"]
    got = {"codes": frames.payload, "clipped": np.array(per["clipped"], dtype=np.int64)}
    if "attack_active" in per:
        got["attack_active"] = np.array(per["attack_active"], dtype=bool)
        assert frames.header["attack_model"] == "smart"
    return got


@pytest.mark.parametrize("name", list(VECTORS))
def test_adc_quantises_and_clips_like_the_adc_description_in_one_frame_and_split(name):
    jig.check_vector(AdcFramer, VECTORS[name], extract)


def test_adc_golden_vectors_are_what_their_generator_writes():
    jig.check_generator_reproduces("adc_framer")


def test_adc_golden_vectors_cover_rails_clipping_and_both_sample_kinds():
    for name, v in VECTORS.items():
        codes = v["outputs"]["codes"]
        assert codes.max() == 2047 and codes.min() == -2048 and v["outputs"]["clipped"].sum() > 0, name
        assert codes.shape[-1] == (2 if name.startswith("iq") else 256), name


def test_adc_rounds_to_the_nearest_code_away_from_ties():
    """A quarter LSB either side of a code gives that code, for I and for Q."""
    scene = load_scene(str(jig.GOLDEN / "adc_small_iq.toml"))
    lsb = scene.adc_full_scale / 2 ** (scene.adc_bits - 1)
    codes = np.arange(-2048, 2048, 16)
    x = np.empty((1, 4, 256), np.complex64)
    x[0] = ((codes + 0.25) * lsb + 1j * (codes - 0.25) * lsb).reshape(4, 64).repeat(4, axis=1)
    out = AdcFramer(scene=str(jig.GOLDEN / "adc_small_iq.toml")).process(jig.wire(Frame.of(x, cycle=0, cycles=1), 1))
    expected = codes.reshape(4, 64).repeat(4, axis=1)
    np.testing.assert_array_equal(out.payload[0, ..., 0], expected)
    np.testing.assert_array_equal(out.payload[0, ..., 1], expected)
    assert out.header["per_cycle"]["clipped"] == [0]


def test_adc_refuses_an_attack_for_other_cycles_naming_both_frames():
    rx = np.zeros((2, 4, 256), np.float32)
    attack = np.zeros((3, 1, 256), np.float32)
    adc = AdcFramer(scene=str(jig.GOLDEN / "adc_small_i.toml"))
    with pytest.raises(ValueError, match=r"attack frame seq 9 \(3 cycles, float32 \(3, 1, 256\), gate_by_on_air "
                                         r"False\) does not fit the received float32 \(2, 4, 256\)"):
        adc.process(jig.wire(Frame.of(rx, cycles=2), 9), jig.wire(Frame.of(attack, cycles=3), 9))


def test_adc_refuses_a_gated_attack_it_cannot_gate_naming_the_frame():
    from carav_blocks.adc_framer import AdcFramer
    rho = np.tile(RHO, (2, 1))
    rx, _, attack, _ = front_end("beat", model="reactive", rarms=3.0)(rho, 0, 6)
    adc, data = AdcFramer(scene=SCENE), rx.payload
    cases = {
        "no on_air in rx": wire(Frame.of(data, cycle=0, cycles=2), 6),
        r"rx's on_air is bool \(2, 32\)": wire(Frame.of(data, cycle=0, cycles=2).derive(
            keep_data=True, arrays={"on_air": rho[:, :32]}), 6),
        r"rx's on_air is uint8 \(2, 64\)": wire(Frame.of(data, cycle=0, cycles=2).derive(
            keep_data=True, arrays={"on_air": rho.view(np.uint8)}), 6),
    }
    for problem, bad_rx in cases.items():
        with pytest.raises(ValueError, match=r"frame seq 6 \(cycles 0..1\): a reactive attack is gated .*" + problem):
            adc.process(bad_rx, attack)
    no_active = wire(Frame.of(attack.payload, cycles=2, gate_by_on_air=True), 6)
    with pytest.raises(ValueError, match="attack_active is None, not one bool per cycle"):
        adc.process(rx, no_active)
    silent_but_on = wire(Frame.of(None, cycles=2, gate_by_on_air=True, per_cycle={"attack_active": [True, False]}), 6)
    with pytest.raises(ValueError, match=r"switched on \(\[True, False\]\) but sends no replies"):
        adc.process(rx, silent_but_on)
    not_a_flag = wire(Frame.of(attack.payload, cycles=2, gate_by_on_air=1, per_cycle={"attack_active": [True] * 2}), 6)
    with pytest.raises(ValueError, match="attack frame seq 6 .* gate_by_on_air 1\\) does not fit"):
        adc.process(rx, not_a_flag)
    ungated = wire(Frame.of(attack.payload, cycles=2, per_cycle={"attack_active": [True] * 2}), 6)   # flag lost
    with pytest.raises(ValueError, match=rf"attack frame seq 6 .*float32 \(1, 64, {N_S}\).* does not fit"):
        adc.process(rx, ungated)
    assert adc.process(rx, attack).header["per_cycle"]["attack_active"] == [True, True]


@pytest.mark.parametrize("iq", [False, True])
def test_adc_codes_count_nan_and_inf_inputs_apart_from_clipping(iq):
    from carav_stream.radar.adc import adc, adc_codes
    from carav_stream.radar.scene_loader import load_scene
    scene = load_scene("table1", {"iq": iq})
    dtype = np.complex64 if iq else np.float32
    rx = np.zeros((3, 64, scene.n_samples), dtype)
    rx[1, 3, 5] = np.nan
    rx[1, 7, 9] = np.inf
    rx[2, 0, 0] = -np.inf
    rx[2, 0, 1] = 10 * scene.adc_full_scale          # a real clip beside a non-finite sample
    if iq:
        rx[1, 3, 6] = complex(0.0, np.nan)            # Q alone non-finite: one sample
    codes, clipped, nonfinite = adc_codes(scene, rx)
    assert nonfinite.tolist() == [0, 3 if iq else 2, 1] and clipped.tolist() == [0, 0, 1]
    assert codes.dtype == np.int16 and codes[1, 3, 5].tolist() == ([0, 0] if iq else 0)
    frames, _ = adc(scene, rx)                        # the float path keeps them visible
    assert np.isnan(frames[1, 3, 5]) and np.isnan(frames[2, 0, 0]) and np.isfinite(frames[0]).all()
