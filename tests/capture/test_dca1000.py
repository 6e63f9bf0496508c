"""The DCA1000 reader against a writer made from TI's layout description, over receivers, lanes, bits and types."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.capture.dca1000 import Layout, complete_cycles, decode, read_cycles
from tests.capture.ti_dca1000 import capture_bytes


def codes(rng, shape, bits):
    return rng.integers(-(2 ** (bits - 1)), 2 ** (bits - 1), size=shape).astype(np.int16)


@pytest.mark.parametrize("encoding", ["twos_complement", "offset_binary"])
@pytest.mark.parametrize("lanes", [2, 4])
@pytest.mark.parametrize("complex_data", [False, True])
@pytest.mark.parametrize("n_rx", [1, 2, 4])
@pytest.mark.parametrize("bits", [12, 14, 16])
def test_every_receiver_and_sample_comes_back_where_the_radar_put_it(complex_data, n_rx, bits, lanes, encoding):
    layout = Layout(n_rx=n_rx, n_samples=8, n_chirps=3, complex=complex_data, adc_bits=bits, lanes=lanes,
                    encoding=encoding)
    x = codes(np.random.default_rng(n_rx * bits), (2 * 3, n_rx, 8, *((2,) if complex_data else ())), bits)
    got = decode(np.frombuffer(capture_bytes(x, complex_data, bits, lanes, encoding), "<i2"), layout)
    assert got.shape == (2, 3, n_rx, 8, *((2,) if complex_data else ()))
    np.testing.assert_array_equal(got.reshape(x.shape), x)


def test_a_known_complex_pair_is_read_as_ti_documents_it():
    # one chirp, one receiver, two samples: words I0, I1, Q0, Q1 = 1, 2, 3, 4 -> samples 1+3j and 2+4j
    got = decode(np.array([1, 2, 3, 4], "<i2"), Layout(n_rx=1, n_samples=2, n_chirps=1, complex=True))
    np.testing.assert_array_equal(got[0, 0, 0], [[1, 3], [2, 4]])
    # a 12-bit ADC's -1 arrives as 4095
    got = decode(np.array([4095, 2047], "<i2"), Layout(n_rx=1, n_samples=2, n_chirps=1, complex=False, adc_bits=12))
    np.testing.assert_array_equal(got.ravel(), [-1, 2047])


def test_known_four_lane_and_offset_binary_words_are_read_as_ti_documents_them():
    # 4 lanes, complex, one sample: I of lanes 1..4 then Q of lanes 1..4; two receivers enabled, lanes 3, 4 zero
    got = decode(np.array([1, 2, 0, 0, 5, 6, 0, 0], "<i2"),
                 Layout(n_rx=2, n_samples=1, n_chirps=1, complex=True, lanes=4))
    np.testing.assert_array_equal(got[0, 0], [[[1, 5]], [[2, 6]]])
    # 4 lanes, real, two samples: sample 0 of lanes 1..4, then sample 1
    got = decode(np.array([1, 2, 3, 4, 5, 6, 7, 8], "<i2"),
                 Layout(n_rx=4, n_samples=2, n_chirps=1, complex=False, lanes=4))
    np.testing.assert_array_equal(got[0, 0], [[1, 5], [2, 6], [3, 7], [4, 8]])
    # offset binary: 0x8000 is 0, 0x7FFF is -1, 0xFFFF is 32767; 12 bits: 0x800 is 0, 0x000 is -2048
    got = decode(np.array([0x8000, 0x7FFF, 0xFFFF, 0], "<u2").view("<i2"),
                 Layout(n_rx=1, n_samples=4, n_chirps=1, complex=False, encoding="offset_binary"))
    np.testing.assert_array_equal(got.ravel(), [0, -1, 32767, -32768])
    got = decode(np.array([0x800, 0x000, 0xFFF, 0x7FF], "<i2"),
                 Layout(n_rx=1, n_samples=4, n_chirps=1, complex=False, adc_bits=12, encoding="offset_binary"))
    np.testing.assert_array_equal(got.ravel(), [0, -2048, 2047, -1])


@settings(max_examples=60, deadline=None)
@given(n_rx=st.integers(1, 4), half=st.integers(1, 6), n_chirps=st.integers(1, 4), cycles=st.integers(1, 3),
       complex_data=st.booleans(), lanes=st.sampled_from([2, 4]), bits=st.sampled_from([12, 14, 16]),
       encoding=st.sampled_from(["twos_complement", "offset_binary"]), seed=st.integers(0, 2 ** 16))
def test_reading_is_the_inverse_of_writing_for_any_layout(n_rx, half, n_chirps, cycles, complex_data, lanes, bits,
                                                          encoding, seed):
    layout = Layout(n_rx, 2 * half, n_chirps, complex_data, bits, lanes, encoding)
    x = codes(np.random.default_rng(seed), (cycles * n_chirps, n_rx, 2 * half, *((2,) if complex_data else ())),
              bits)
    got = decode(np.frombuffer(capture_bytes(x, complex_data, bits, lanes, encoding), "<i2"), layout)
    np.testing.assert_array_equal(got.reshape(x.shape), x)


def test_a_truncated_capture_gives_its_whole_cycles_and_the_bytes_left(tmp_path):
    layout = Layout(n_rx=2, n_samples=4, n_chirps=2, complex=True)
    x = codes(np.random.default_rng(1), (3 * 2, 2, 4, 2), 16)
    path = tmp_path / "adc.bin"
    path.write_bytes(capture_bytes(x, True)[:-6])
    assert complete_cycles(path, layout) == (2, layout.bytes_per_cycle - 6)
    got = read_cycles(path, layout, 1, 1, rx=1)
    np.testing.assert_array_equal(got[0], x.reshape(3, 2, 2, 4, 2)[1, :, 1])


def test_layouts_that_cannot_be_captured_are_refused():
    with pytest.raises(ValueError, match="n_rx 1..4"):
        Layout(n_rx=5, n_samples=8, n_chirps=1, complex=False)
    with pytest.raises(ValueError, match="must be even"):
        Layout(n_rx=1, n_samples=7, n_chirps=1, complex=True)
    with pytest.raises(ValueError, match="lanes must be 2"):
        Layout(n_rx=1, n_samples=8, n_chirps=1, complex=False, lanes=3)
    with pytest.raises(ValueError, match="encoding must be one of"):
        Layout(n_rx=1, n_samples=8, n_chirps=1, complex=False, encoding="gray")
    Layout(n_rx=1, n_samples=7, n_chirps=1, complex=True, lanes=4)   # 4 lanes carry whole samples: any count
    with pytest.raises(ValueError, match="whole cycles"):
        decode(np.zeros(5, "<i2"), Layout(n_rx=1, n_samples=4, n_chirps=1, complex=False))
