"""The detector's per-frame path against plain references: exact int64 sums of squares of the ADC codes, and the
verdict picked from D(k) chirp by chirp in Python.

    ||R_k||_r = lsb sqrt(sum_m code[m]^2 / N_s)       (I/Q: code_I^2 + code_Q^2; an exact integer sum)
    Q = max_k D(k) (first k on ties), by_d1 = rho(k_max); an invalid cycle: Q = inf, k_max = -1, by_d1 False
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.detect.detector import adc_chirp_rms, chirp_rms_codes, detect_from_rms

EDGES = np.array([-32768, 32767, -32767, 0, 1, -1, 2047, -2048], np.int16)


@st.composite
def code_frames(draw):
    """int16 codes (n_cycles, n_chirps, n_samples[, 2]) of random shape (odd lengths, more rows than one chunk of
    the kernel), uniform over int16 or over a 12-bit ADC's codes, with rails, zero chirps and all-zero cycles."""
    iq = draw(st.booleans())
    n_cycles, n_chirps = draw(st.integers(1, 6)), draw(st.sampled_from([1, 2, 5, 64, 130]))
    n_samples = draw(st.sampled_from([1, 2, 3, 7, 64, 255, 1081]))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    shape = (n_cycles, n_chirps, n_samples) + ((2,) if iq else ())
    top = draw(st.sampled_from([1, 2048, 32768]))
    codes = rng.integers(-top, top, size=shape, dtype=np.int64).astype(np.int16)
    flat = codes.reshape(-1)
    hits = rng.random(flat.size) < draw(st.sampled_from([0.0, 0.1, 1.0]))
    flat[hits] = rng.choice(EDGES, size=int(hits.sum()))
    codes[rng.random(n_cycles) < 0.2] = 0                       # all-zero cycles
    codes[:, rng.random(n_chirps) < 0.2] = 0                    # all-zero chirps
    nonfinite = rng.choice([0, 0, 0, 1, 7], size=n_cycles).tolist()
    lsb = draw(st.sampled_from([1.0, 0.5, 2.916976976379289e-06, 3.0]))
    return codes, iq, lsb, nonfinite


def reference_rms(codes: np.ndarray, iq: bool, lsb: float) -> np.ndarray:
    """lsb sqrt(sum code^2 / n) with the sum in exact int64 arithmetic."""
    sq = codes.astype(np.int64) ** 2
    sums = sq.sum(axis=(-2, -1)) if iq else sq.sum(axis=-1)
    n = codes.shape[-2] if iq else codes.shape[-1]
    return float(lsb) * np.sqrt(sums / n)


@settings(max_examples=120, deadline=None)
@given(code_frames())
def test_rms_of_codes_equals_exact_int64_sums_bit_for_bit(frame):
    codes, iq, lsb, nonfinite = frame
    want = reference_rms(codes, iq, lsb)
    got = chirp_rms_codes(codes, lsb, iq=iq)
    assert got.dtype == np.float64 and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    judged = adc_chirp_rms(codes, lsb, iq, nonfinite)            # what the detector node calls per frame
    want[np.array(nonfinite) > 0] = np.nan
    np.testing.assert_array_equal(judged, want)


def reference_verdict(d: np.ndarray, active: np.ndarray, rms: np.ndarray, eta: float):
    """q, k_max, by_d1, invalid, alarm of one cycle from its D(k), chirp by chirp in Python."""
    if not all(math.isfinite(r) for r in rms):
        return math.inf, -1, False, True, True
    values = [(-math.inf if math.isnan(v) else v) for v in d.tolist()]
    k = values.index(max(values))
    q = float(d[k])
    return q, k, bool(active[k]), False, q / eta >= 1.0


@st.composite
def rms_cases(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    n_cycles, n_chirps = draw(st.integers(1, 6)), 2 * draw(st.integers(1, 33))
    rms = np.abs(rng.standard_normal((n_cycles, n_chirps))) * draw(st.sampled_from([0.0, 1e-4, 1.0, 1e6]))
    holes = rng.random(rms.shape) < draw(st.sampled_from([0.0, 0.05]))
    rms[holes] = rng.choice([np.nan, np.inf, 0.0], size=int(holes.sum()))
    rms[rng.random(n_cycles) < 0.2] = 0.0                        # cycles without any energy
    if draw(st.booleans()):                                      # ties: every chirp of a cycle alike
        rms[0] = rms[0, 0]
    rho = np.zeros((n_cycles, n_chirps), bool)
    for i in range(n_cycles):
        rho[i, rng.permutation(n_chirps)[: n_chirps // 2]] = True
    sigma = float(draw(st.sampled_from([0.0, 1e-4, 0.7, 1.0])))
    eta = float(draw(st.sampled_from([0.5, 1.0, 1.5, 4.0])))
    return rms, rho, sigma, eta


@settings(max_examples=150, deadline=None)
@given(rms_cases())
def test_verdicts_equal_the_formulas_chirp_by_chirp_whatever_form_sigma_takes(case):
    rms, rho, sigma, eta = case
    det = detect_from_rms(rms, rho, sigma, eta)
    n_cycles = rms.shape[0]
    for form in (np.float64(sigma), np.full(n_cycles, sigma), np.array([sigma]), np.array(sigma)):
        other = detect_from_rms(rms, rho, form, eta)
        for name in ("rms", "d0", "d1", "d", "rbar", "q", "c", "alarm", "invalid", "k_max", "by_d1"):
            np.testing.assert_array_equal(getattr(other, name), getattr(det, name), err_msg=f"{name}, {form!r}")
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(n_cycles):
            r, a = rms[i], rho[i]
            rbar = det.rbar[i]
            if np.isfinite(r).all():
                assert math.isclose(rbar, math.fsum(r[a]) / (len(r) // 2), rel_tol=1e-14, abs_tol=0.0)
            for k in range(len(r)):
                num, den = abs(r[k] - rbar), rbar + sigma
                d1 = (num / den if den else (math.inf if num > 0 else 0.0 if num == 0 else math.nan))
                d0 = (r[k] / sigma if sigma else (math.inf if r[k] > 0 else 0.0 if r[k] == 0 else math.nan))
                assert np.array_equal([det.d0[i, k], det.d1[i, k]], [d0, d1], equal_nan=True), (i, k)
                assert np.array_equal(det.d[i, k], d1 if a[k] else d0, equal_nan=True)
            q, k_max, by_d1, invalid, alarm = reference_verdict(det.d[i], a, r, eta)
            assert (det.q[i], det.k_max[i], det.by_d1[i], det.invalid[i], det.alarm[i]) == (q, k_max, by_d1,
                                                                                             invalid, alarm)
            assert det.c[i] == q / eta


# chirp_rms_codes sums the squares in float32 first and redoes in float64 every chirp whose float32 sum is not below
# 2^24 (the float32 sum is exact below it, and not below it whenever the true sum is not); once a chunk (32 chirps,
# then 256) is more than a sixth loud, the rest of the frame goes to float64 at once. The tests below pin the sums
# bit for bit at and around 2^24, on the rails, on silent chirps and across quiet and loud chunks.

TWO24 = 2 ** 24


def exact_sums(codes: np.ndarray, iq: bool) -> np.ndarray:
    """Exact integer sums of code^2 per chirp (I/Q: over I and Q too)."""
    sq = codes.astype(np.int64) ** 2
    return sq.sum(axis=(-2, -1)) if iq else sq.sum(axis=-1)


def assert_exact(codes: np.ndarray, iq: bool = False, lsb: float = 1.0) -> None:
    n = codes.shape[-2] if iq else codes.shape[-1]
    want = float(lsb) * np.sqrt(exact_sums(codes, iq) / n)
    got = chirp_rms_codes(codes, lsb, iq=iq)
    assert got.dtype == np.float64 and got.shape == want.shape
    bad = np.flatnonzero(got.reshape(-1) != want.reshape(-1))
    assert bad.size == 0, (f"{bad.size} chirps differ, first at {bad[:5]}: exact sums "
                           f"{exact_sums(codes, iq).reshape(-1)[bad[:5]]}, got {got.reshape(-1)[bad[:5]]}")


def chirp_with_sum(target: int, n: int, amp: float, rng) -> np.ndarray:
    """n int16 codes whose squares sum to exactly `target`: random codes of RMS about `amp` (kept below the target)
    topped up by a few greedy squares, at shuffled positions with random signs."""
    base = np.rint(rng.standard_normal(n - 12) * amp).astype(np.int64)
    while int((base ** 2).sum()) > target:
        base //= 2
    rest, top = target - int((base ** 2).sum()), []
    while rest:
        top.append(math.isqrt(rest))
        rest -= top[-1] ** 2
    assert len(top) <= 12
    c = np.concatenate([base, top, np.zeros(12 - len(top), np.int64)]) * rng.choice([-1, 1], n)
    c = rng.permutation(c).astype(np.int16)
    assert int((c.astype(np.int64) ** 2).sum()) == target
    return c


def test_small_codes_are_exact_bit_for_bit():
    rng = np.random.default_rng(11)
    for shape, top in (((7, 130, 1080), 64), ((3, 64, 1), 4096), ((1, 1, 1081), 124), ((600, 5), 2047)):
        assert_exact(rng.integers(-top, top + 1, size=shape).astype(np.int16))
    assert_exact(np.rint(rng.standard_normal((8, 64, 1080)) * 40).astype(np.int16), lsb=2.916976976379289e-06)


def test_chirp_sums_at_and_around_2_24_are_exact_bit_for_bit():
    rng = np.random.default_rng(12)
    n = 1080
    targets = [TWO24 - 2, TWO24 - 1, TWO24, TWO24 + 1, TWO24 + 2, TWO24 + 3, TWO24 + 7, 2 * TWO24 + 1]
    special = [chirp_with_sum(t, n, amp, rng) for t in targets for amp in (0.0, 40.0, 124.0)]
    special.append(np.full(n, 125, np.int16))                              # 1080 * 125^2 > 2^24, no term near it
    special.append(np.full(n, 124, np.int16))                              # 1080 * 124^2 < 2^24
    for k, c in enumerate(((4096,), (4096, 1), (4095, 90, 9, 3), (4095, 90, 9, 2), (4095, 90, 9, 4))):
        special.append(np.r_[c, np.zeros(n - len(c))].astype(np.int16)[np.roll(np.arange(n), k)])
    special = np.array(special)
    assert {TWO24 - 1, TWO24, TWO24 + 1} <= set(exact_sums(special, False).tolist())
    quiet = np.rint(rng.standard_normal((2, 400, n)) * 40).astype(np.int16)
    slots = rng.choice(quiet[0].size // n, size=len(special), replace=False)
    quiet[0, slots] = special                                              # a few loud chirps in quiet chunks
    quiet[1, ::37] = special[: quiet[1, ::37].shape[0]]
    assert_exact(quiet)
    assert_exact(special)                                                  # every chunk loud
    assert_exact(special[:, None, :])
    assert_exact(np.tile(special, (12, 1)))


def test_a_single_code_on_either_rail_is_exact_bit_for_bit():
    n = 1080
    for code in (-32768, 32767, -32767, 4096, -4096, 4095):
        for other in (0, 1, -1, 3):
            c = np.zeros((300, n), np.int16)                               # the chirp alone in a quiet chunk
            c[5, 17] = code
            c[5, 900] = other
            c[200, 0] = code
            assert_exact(c)
            assert_exact(c[5])
            loud = np.zeros((3, 256, n), np.int16)                         # and in loud chunks
            loud[:, :, 3] = code
            loud[:, 1::2, 700] = other
            assert_exact(loud)


def test_all_zero_chirps_are_exact_zeros_among_quiet_and_loud_ones():
    rng = np.random.default_rng(13)
    n = 1080
    assert_exact(np.zeros((4, 64, n), np.int16))
    assert_exact(np.zeros((0, 64, n), np.int16))
    frame = np.rint(rng.standard_normal((16, 64, n)) * 40).astype(np.int16)
    frame[4:8] = np.clip(rng.standard_normal((4, 64, n)) * 3000, -32768, 32767).astype(np.int16)  # loud chunk
    frame[9:12, ::2] = -32768                                              # a loud chunk of half rails
    frame[:, ::3] = 0                                                      # silent chirps everywhere
    frame[13] = 0
    got = chirp_rms_codes(frame, 1.0)
    assert np.all(got[:, ::3] == 0.0) and np.all(got[13] == 0.0)
    assert_exact(frame)


def test_iq_codes_are_exact_bit_for_bit_at_and_around_2_24():
    rng = np.random.default_rng(14)
    n = 540
    special = np.zeros((12, n, 2), np.int16)
    special[0, 7] = (4096, 0)                                              # 2^24
    special[1, 7] = (4096, 1)                                              # 2^24 + 1
    special[2, 7], special[2, 8] = (4095, 90), (9, 3)                      # 2^24 - 1 over I and Q
    special[3, 7], special[3, 300] = (4095, 90), (9, 4)                    # 2^24 + 6
    special[4, 0] = (-32768, 32767)
    special[5, 1] = (0, -32768)
    special[6, 2] = (1, 32767)
    for k, t in enumerate((TWO24 - 1, TWO24, TWO24 + 1, TWO24 + 3, 3 * TWO24 + 1)):
        special[7 + k] = chirp_with_sum(t, 2 * n, 80.0, rng).reshape(n, 2)
    assert {TWO24 - 1, TWO24, TWO24 + 1} <= set(exact_sums(special, True).tolist())
    quiet = np.rint(rng.standard_normal((3, 256, n, 2)) * 28).astype(np.int16)
    quiet[1, 40: 40 + len(special)] = special
    assert_exact(quiet, iq=True)
    assert_exact(special, iq=True)
    assert_exact(np.tile(special, (30, 1, 1)), iq=True)
    assert_exact(special[3], iq=True)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.booleans())
def test_frames_mixing_quiet_straddling_and_loud_chunks_are_exact_bit_for_bit(seed, iq):
    """Runs of chirps at RMS levels from silent to the rails (around 2^24 at 1080 samples: 124.6 codes), so that
    frames switch to float64 at any chunk, or never, with loud chirps redone before the switch."""
    rng = np.random.default_rng(seed)
    n_samples = int(rng.choice([540, 1080, 1081]))
    n_chirps = int(rng.integers(1, 1300))
    levels = np.array([0.0, 1.0, 40.0, 118.0, 124.0, 125.0, 131.0, 2000.0, 40000.0])
    runs = rng.integers(1, 300, size=n_chirps)
    per_chirp = np.repeat(rng.choice(levels, size=runs.size), runs)[:n_chirps]
    shape = (n_chirps, n_samples // 2, 2) if iq else (n_chirps, n_samples)
    amp = per_chirp.reshape((-1,) + (1,) * (len(shape) - 1)) / (math.sqrt(2) if iq else 1.0)
    codes = np.clip(np.rint(rng.standard_normal(shape) * amp), -32768, 32767).astype(np.int16)
    assert_exact(codes, iq=iq)
