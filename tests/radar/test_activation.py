"""Activation sequences: balance, uniformity, reproducibility, LFSR period and Berlekamp-Massey."""
import itertools
import math

import numpy as np
import pytest
import scipy.stats
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.radar.activation import ActivationSource, berlekamp_massey, lfsr_continue, lowest_half

# Maximal-length taps (Xilinx XAPP052 table), recurrence s[n] = XOR s[n - t].
PRIMITIVE_TAPS = [(3, 2), (4, 3), (5, 3), (6, 5), (7, 6), (8, 6, 5, 4), (9, 5), (10, 7), (11, 9), (12, 6, 4, 1),
                  (13, 4, 3, 1), (15, 14), (16, 15, 13, 4), (17, 14), (20, 17), (23, 18)]


@settings(max_examples=30, deadline=None)
@given(kind=st.sampled_from(["secure", "seeded", "lfsr"]), half=st.integers(1, 80), n_cycles=st.integers(0, 20))
def test_every_row_has_exactly_half_the_chirps_active(kind, half, n_cycles):
    src = ActivationSource(kind, seed=3 if kind != "secure" else None)
    rho = src.next(n_cycles, 2 * half)
    assert rho.dtype == np.bool_ and rho.shape == (n_cycles, 2 * half)
    assert (rho.sum(axis=1) == half).all()


@pytest.mark.parametrize("kind", ["secure", "seeded"])
def test_balanced_patterns_are_uniformly_distributed(kind):
    # n = 6: C(6, 3) = 20 patterns, each should appear with probability 1/20.
    src = ActivationSource(kind, seed=11 if kind == "seeded" else None)
    rho = src.next(20000, 6)
    codes = rho @ (1 << np.arange(6))
    patterns = [sum(1 << i for i in c) for c in itertools.combinations(range(6), 3)]
    counts = np.array([np.count_nonzero(codes == p) for p in patterns])
    assert counts.sum() == 20000
    assert scipy.stats.chisquare(counts).pvalue > 1e-4


def test_seeded_source_is_reproducible_and_secure_is_not():
    a = ActivationSource("seeded", seed=5).next(50, 64)
    b = ActivationSource("seeded", seed=5).next(50, 64)
    assert np.array_equal(a, b)
    s1 = ActivationSource("secure").next(50, 64)
    s2 = ActivationSource("secure").next(50, 64)
    assert not np.array_equal(s1, s2)


@pytest.mark.parametrize("kind", ["seeded", "lfsr"])
def test_stream_continues_across_calls(kind):
    src = ActivationSource(kind, seed=9)
    parts = np.concatenate([src.next(3, 64), src.next(7, 64)])
    assert np.array_equal(parts, ActivationSource(kind, seed=9).next(10, 64))


def test_source_arguments_are_checked():
    with pytest.raises(ValueError, match="unknown 'quantum'"):
        ActivationSource("quantum")
    with pytest.raises(ValueError, match="'seeded' needs seed"):
        ActivationSource("seeded")
    with pytest.raises(ValueError, match="'secure' takes no seed"):
        ActivationSource("secure", seed=1)
    with pytest.raises(ValueError, match="n_chirps must be even"):
        ActivationSource().next(1, 7)


@pytest.mark.parametrize("taps", [(3, 2), (5, 3), (8, 6, 5, 4), (10, 7)])
def test_lfsr_has_maximal_period(taps):
    degree = max(taps)
    period = 2 ** degree - 1
    bits = ActivationSource("lfsr", seed=1, taps=taps).lfsr_bits(2 * period + degree)
    assert np.array_equal(bits[:period], bits[period: 2 * period])
    # no shorter period: the state sequence over one period visits every nonzero state once
    states = {tuple(bits[i: i + degree]) for i in range(period)}
    assert len(states) == period
    assert bits[:period].sum() == 2 ** (degree - 1)      # m-sequence balance property


def test_lfsr_source_uses_manchester_pairs():
    src = ActivationSource("lfsr", seed=1, taps=(5, 3))
    bits = ActivationSource("lfsr", seed=1, taps=(5, 3)).lfsr_bits(8)
    rho = src.next(1, 16)[0]
    assert np.array_equal(rho[0::2], bits) and np.array_equal(rho[1::2], ~bits)


@settings(max_examples=16, deadline=None)
@given(taps=st.sampled_from(PRIMITIVE_TAPS), seed=st.integers(1, 2 ** 20))
def test_berlekamp_massey_recovers_lfsr_from_2l_bits(taps, seed):
    degree = max(taps)
    seed = seed % (2 ** degree - 1) + 1
    bits = ActivationSource("lfsr", seed=seed, taps=taps).lfsr_bits(2 * degree + 50)
    length, found = berlekamp_massey(bits[: 2 * degree])
    assert length == degree and found == tuple(sorted(taps))
    # and it predicts the rest of the stream
    assert np.array_equal(lfsr_continue(bits[:degree], found, 50 + degree), bits[degree:])


def test_berlekamp_massey_golden_sequences():
    assert berlekamp_massey([0, 0, 0, 0]) == (0, ())
    assert berlekamp_massey([0, 0, 0, 1]) == (4, (4,))     # impulse: needs the full length (Massey 1969)
    assert berlekamp_massey([1, 1, 1, 1, 1]) == (1, (1,))  # s[n] = s[n-1]
    assert berlekamp_massey([1, 0, 1, 0, 1, 0]) == (2, (2,))


def test_berlekamp_massey_finds_no_short_lfsr_in_secure_bits():
    bits = ActivationSource("secure").next(16, 64)[:, 0::2].ravel()        # 512 bits
    length, _ = berlekamp_massey(bits)
    # linear complexity of random bits is n/2 +- a few
    assert abs(length - 256) <= 12, length
    assert math.isclose(np.mean(bits), 0.5, abs_tol=0.1)


def test_balanced_rows_have_exactly_half_active_per_cycle_and_every_pattern_can_occur():
    from carav_stream.radar.activation import balanced_rows
    rho = balanced_rows(np.random.default_rng(0), 4000, 4)
    assert rho.dtype == bool and np.all(rho.sum(axis=1) == 2)
    patterns = {tuple(r) for r in rho.tolist()}
    assert len(patterns) == 6                               # C(4, 2): uniform over the balanced rows


@settings(max_examples=200, deadline=None)
@given(keys=st.lists(st.lists(st.integers(0, 3), min_size=6, max_size=6), min_size=1, max_size=20),
       as_float=st.booleans())
def test_lowest_half_picks_what_a_stable_sort_picks_ties_included(keys, as_float):
    """Selection instead of sorting: the same chirps as a stable argsort's first half, also among equal keys (few
    distinct values force ties; the secure source's 64-bit keys can tie too)."""
    k = np.asarray(keys, dtype=np.float64 if as_float else np.uint64)
    order = np.argsort(k, axis=1, kind="stable")
    expected = np.zeros(k.shape, dtype=bool)
    np.put_along_axis(expected, order[:, :3], True, axis=1)
    np.testing.assert_array_equal(lowest_half(k), expected)


def test_lowest_half_of_random_keys_equals_the_stable_sort_on_wide_rows():
    k = np.random.default_rng(5).random((500, 64))
    expected = np.zeros(k.shape, dtype=bool)
    np.put_along_axis(expected, np.argsort(k, axis=1, kind="stable")[:, :32], True, axis=1)
    np.testing.assert_array_equal(lowest_half(k), expected)
