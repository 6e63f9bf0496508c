"""adc_framer against golden vectors written from the ADC's description, and its refusals."""
import numpy as np
import pytest

from carav_blocks.adc_framer import AdcFramer
from carav_stream.frames import Frame
from carav_stream.radar.scene import load_scene
from tests.blocks import jig

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
