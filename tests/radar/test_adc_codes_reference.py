"""adc_codes against a plain reference written from the ADC's description: rint, clip, count, one array at a time.

    code = clip(rint(float32(x + a) * float32(1 / lsb)), -2^(b-1), 2^(b-1) - 1),   lsb = full_scale / 2^(b-1)
    NaN/Inf at the input: code 0, counted in nonfinite, not in clipped; a sample counts once (I or Q)
"""
from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.radar import adc as adc_mod
from carav_stream.radar.scene_loader import scene_from_dict

SMALL = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 8,
         "n_samples": 256, "radar_speed_kmh": 100.0,
         "targets": [{"range_m": 43.0, "velocity_kmh": 96.0, "rcs_m2": 100.0}]}
FULL_SCALE = 0.006


@cache
def scene(iq: bool, bits: int, full_scale: float = FULL_SCALE):
    return scene_from_dict({**SMALL, "iq": iq, "adc_bits": bits, "adc_full_scale": full_scale}, "small.toml")


def reference_codes(rx: np.ndarray, add: np.ndarray | None, iq: bool, bits: int):
    """The codes, clip and NaN/Inf counts of rx (+ add) written out plainly over the whole array."""
    lsb = FULL_SCALE / 2 ** (bits - 1)
    hi, lo = 2 ** (bits - 1) - 1, -(2 ** (bits - 1))
    x = rx if add is None else (rx + add).astype(rx.dtype)          # the sum in the samples' own precision
    parts = np.stack([x.real, x.imag], axis=-1) if iq else x       # float32 I (and Q)
    with np.errstate(invalid="ignore", over="ignore"):
        v = np.rint(parts.astype(np.float32) * np.float32(1.0 / lsb))
    bad = ~np.isfinite(v)
    over = ~bad & ((v > hi) | (v < lo))
    codes = np.where(bad, 0, np.clip(np.where(bad, 0, v), lo, hi)).astype(np.int16)
    if iq:                                                          # a sample is clipped or bad if its I or Q is
        over, bad = over.any(axis=-1), bad.any(axis=-1)
    n = rx.shape[0]
    return codes, over.reshape(n, -1).sum(axis=1), bad.reshape(n, -1).sum(axis=1)


@st.composite
def signals(draw):
    """rx (and an attack) of random shape with values that land on and beyond the rails, on half codes, at 0,
    and NaN/Inf; bits from 1 to 16. "bottom_only" crosses the lower rail alone (no NaN, nothing above)."""
    iq, bits = draw(st.booleans()), draw(st.integers(1, 16))
    n, k, m = draw(st.integers(1, 5)), draw(st.integers(1, 4)), draw(st.integers(1, 37))
    lsb = FULL_SCALE / 2 ** (bits - 1)
    hi = 2 ** (bits - 1) - 1
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    size = (n, k, m, 2) if iq else (n, k, m)
    kind = draw(st.sampled_from(["mixed", "all_zero", "full_scale", "clipping", "bottom_only"]))
    low, high = {"clipping": (-3.0, 3.0), "bottom_only": (-3.0, 0.0)}.get(kind, (-0.7, 0.7))
    special = [-np.inf, -(hi + 1) * lsb, -(hi + 1.5) * lsb, -3 * FULL_SCALE, -0.5 * lsb, -0.0]
    if kind != "bottom_only":
        special += [0.0, np.nan, np.inf, hi * lsb, (hi + 0.5) * lsb, (hi + 1) * lsb, 0.5 * lsb, 1.5 * lsb,
                    3 * FULL_SCALE]
    if kind == "all_zero":
        parts = np.zeros(size)
    elif kind == "full_scale":
        parts = rng.choice([hi * lsb, -(hi + 1) * lsb], size=size)
    else:
        parts = rng.uniform(low, high, size) * FULL_SCALE
        mask = rng.random(size) < draw(st.sampled_from([0.0, 0.05, 0.3]))
        parts[mask] = rng.choice(special, size=int(mask.sum()))
    parts = parts.astype(np.float32)
    rx = parts.view(np.complex64)[..., 0] if iq else parts       # I, Q as they are (1j * inf would add a NaN)
    add_shape = draw(st.sampled_from([None, (n, k, m), (n, 1, m), (1, 1, m), (1, k, m)]))
    add = None
    if add_shape is not None:
        a = rng.uniform(-1.0, 0.0 if kind == "bottom_only" else 1.0, add_shape + ((2,) if iq else ()))
        a = (a * FULL_SCALE).astype(np.float32)
        if kind != "bottom_only" and draw(st.booleans()):
            a.reshape(-1)[rng.integers(a.size)] = np.nan
        add = a.view(np.complex64)[..., 0] if iq else a
    chunk = draw(st.sampled_from([1, 7, 2 * m * k, 1 << 18]))   # elements a chunk: a cycle or two at a time, or all
    return iq, bits, rx, add, chunk


@settings(max_examples=200, deadline=None)
@given(signals())
def test_adc_codes_equal_plain_rint_clip_and_counts_of_the_whole_array(case):
    iq, bits, rx, add, chunk = case
    want = reference_codes(rx, add, iq, bits)
    keep = adc_mod.CHUNK_ELEMENTS
    adc_mod.CHUNK_ELEMENTS = chunk
    try:
        got = adc_mod.adc_codes(scene(iq, bits), rx, add=add)
        into = np.full(want[0].shape, 12345, np.int16)
        got_into = adc_mod.adc_codes(scene(iq, bits), rx, into, add=add)
    finally:
        adc_mod.CHUNK_ELEMENTS = keep
    assert got[0].dtype == np.int16 and got_into[0] is into
    for g in (got, got_into):
        np.testing.assert_array_equal(g[0], want[0])
        assert g[1].tolist() == want[1].tolist(), "clipped"
        assert g[2].tolist() == want[2].tolist(), "nonfinite"


@pytest.mark.parametrize("iq", [False, True])
def test_adc_codes_round_half_codes_to_even_and_clip_at_both_rails_in_one_cycle(iq):
    """A cycle holding every kind of edge at once: ties go to the even code (rint), +hi+0.5 rounds onto the rail
    above and counts as clipped, -(hi+1)-0.5 rounds to the bottom rail itself and does not count. The full scale
    is a power of two, so that x / lsb is exact and the half codes are ties."""
    bits, full_scale = 4, 2.0 ** -7                            # codes -8 .. 7
    lsb = full_scale / 8
    values = np.array([0.5, 1.5, 2.5, -0.5, -1.5, 7.0, 7.5, 8.0, -8.0, -8.5, -9.0, np.nan, np.inf], np.float32)
    rx = (values * np.float32(lsb)).astype(np.float32)[None, None, :]
    if iq:   # I the values, Q the same reversed
        rx = np.ascontiguousarray(np.stack([rx, rx[..., ::-1]], axis=-1)).view(np.complex64)[..., 0]
    codes, clipped, nonfinite = adc_mod.adc_codes(scene(iq, bits, full_scale), rx)
    want_i = [0, 2, 2, 0, -2, 7, 7, 7, -8, -8, -8, 0, 0]
    got_i = codes[0, 0, :, 0] if iq else codes[0, 0]
    assert got_i.tolist() == want_i
    if iq:   # Q holds the same values reversed: the two NaN/Inf samples of each are different samples
        assert codes[0, 0, :, 1].tolist() == want_i[::-1]
        assert clipped.tolist() == [5] and nonfinite.tolist() == [4]
    else:
        assert clipped.tolist() == [3] and nonfinite.tolist() == [2]
