"""Opt-in detectors beyond the paper, closing gaps the RMS detector C(eta) leaves open.

spectral_silent_test   range FFT of the *silent* chirps against an exact exponential threshold. A coherent attacker
                       (ghost) hides under D0 in raw RMS but concentrates N_s times its per-sample power in one
                       range bin; noise alone gives |X_b|^2 / (N_s sigma_n^2) ~ Exp(1), independent over bins.
integrated_silent_test the same bins summed over the silent chirps of a cycle (non-coherent integration): a ghost
                       sits in the same range bin of every silent chirp, so its power adds M times while the
                       noise's spread grows as sqrt(M); under noise each bin's sum is Gamma(M, 1), independent over
                       bins, so the threshold is exact too. It catches ghosts far below the single-chirp test.
coherent_silent_test   the range-Doppler map of the silent chirps alone (the radar's own map, built from the other
                       half of the cycle): a ghost that transmits in every chirp period integrates coherently
                       there exactly as in the radar's map of the active chirps, so whatever the radar's CFAR
                       would report, this test sees with the same gain. Cells are Exp(1) under noise (see
                       detect/cfar.py); they are correlated across Doppler, so the threshold ln(cells / pf) is
                       the union bound: the false-alarm rate per cycle is at most pf (slightly below).
spill_test             energy a reply still carries into a silent slot after the longest round trip the radar can see
                       (a repeater cannot stop the instant the radar does): the samples of each silent slot that
                       follows an active one, from ``first_sample`` on (the caller's bound: every echo the receiver
                       passes has ended there, and the IF filter has settled), range FFT, bin powers summed over
                       those slots. Under noise a bin's sum is Gamma(M, 1), M the slots used in the cycle, whatever
                       the targets' echo power: the threshold is exact. What it cannot see: a reply whose delay
                       (distance plus latency) stays within the longest visible round trip (it has ended before the
                       window), and a spill whose beat S (delay - t_chirp) lies outside the IF band (docs/DETECTION.md).
cusum_silent_power     CUSUM across cycles of the normalised mean silent-chirp power, against slowly ramping
                       attackers; sigma_n comes from calibration and is never re-estimated under attack.

Receiver arrays (``receivers=True``: frames (n_cycles, n_rx, n_chirps, n_samples), rho shared by the receivers, the
noise independent per receiver with the same sigma_n). Every normalised bin power |X_{r,b}|^2 / (N_s sigma_n^2) is
Exp(1) under noise, independent over receivers, so a sum over the n_rx receivers is Gamma(n_rx, 1): the degrees of
freedom add, as in the RMS detector's combined law (detect/receivers.py), and the tests sum over the receivers
non-coherently:

    spectral     per (silent chirp, bin) the sum over receivers, Gamma(n_rx, 1), independent over chirps and bins:
                 the threshold of the max over them is exact, as for one receiver
    integrated   per bin the sum over receivers and silent chirps, Gamma(n_rx M, 1): exact
    spill        per bin the sum over receivers and used slots, Gamma(n_rx M, 1): exact
    coherent     per range-Doppler cell the sum of the receivers' maps, Gamma(n_rx, 1) per cell; cells correlated
                 across Doppler as for one receiver, so the same union bound: P(Gamma(n_rx, 1) >= t) = pf / cells
    CUSUM        `silent_power_z` of the combined chirp RMS (`chirp_rms(..., receivers=True)`) with n_rx nu real
                 degrees of freedom per chirp (``n_rx=``)

Why the sum and not the largest receiver. One attacker (a ghost) reaches every receiver with the same power (unit
modulus steering, the contract's far field), so the sum holds n_rx times its power in the bin against a noise whose
mean grows n_rx times but whose spread grows only sqrt(n_rx) times: the sum gains the receivers' integration. The max
over receivers (n_rx times as many Exp(1) cells, exact too since they are independent) gains nothing from a signal on
every receiver and only raises its threshold by the larger count; it would win only against energy on one receiver
alone, which a single far-field transmitter does not make. With one receiver every test is the one-receiver test,
bit for bit.

All are pure functions on numpy arrays, vectorised over cycles (and receivers), with the shapes and dtypes of
`detector.detect`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft
from scipy import optimize, stats

from carav_stream.detect.detector import _check_frames, check_rho
from carav_stream.detect.rdmap import rd_power
from carav_stream.detect.receivers import receiver_count

__all__ = ["exact_bins", "gamma_threshold", "spectral_silent_test", "spectral_threshold", "SpectralResult",
           "integrated_silent_test", "integrated_threshold", "coherent_silent_test", "spill_test", "spill_tests",
           "SpillResult", "calibrate_threshold", "cusum_silent_power", "cusum_threshold", "silent_power_z"]


@dataclass(frozen=True)
class SpectralResult:
    """stat float64 (n_cycles,): max normalised silent-chirp bin power (summed over the receivers); peak_bin int
    (n_cycles,); threshold float; alarm bool (n_cycles,); n_bins_tested int (silent chirps x bins per chirp);
    n_rx int: the receivers summed in every bin."""

    stat: np.ndarray
    peak_bin: np.ndarray
    threshold: float
    alarm: np.ndarray
    n_bins_tested: int
    n_rx: int = 1


def exact_bins(n_samples: int, iq: bool) -> int:
    """Range bins per chirp whose power is exactly Exp(1) under white Gaussian noise: all N_s for I/Q, bins
    1..(N_s - 1) // 2 of the real FFT for I only (DC and Nyquist are chi2(1)): none for an I-only chirp of 1 or 2."""
    return n_samples if iq else (n_samples - 1) // 2


def _need_bins(x: np.ndarray, test: str) -> None:
    """Refuse frames whose chirps have no bin with an exact law (an I-only chirp of 1 or 2 samples)."""
    n_s = x.shape[-1]
    if exact_bins(n_s, np.iscomplexobj(x)) == 0:
        raise ValueError(f"the {test} test needs a range bin with an exact law, and N_s = {n_s} I only has none "
                         "(DC and Nyquist are chi2(1)): it takes N_s >= 3, or I/Q samples")


def spectral_threshold(pf: float, n_bins_tested: int) -> float:
    """t with P(max of n i.i.d. Exp(1) >= t) = pf, exactly: t = -log(1 - (1 - pf)^(1/n)), n >= 1."""
    if not 0 < pf < 1:
        raise ValueError(f"pf: must be in (0, 1), got {pf!r}")
    if n_bins_tested < 1:
        raise ValueError(f"n_bins_tested: must be >= 1, got {n_bins_tested}")
    return float(-np.log(-np.expm1(np.log1p(-pf) / n_bins_tested)))


def _cycles(frames, rho, receivers: bool) -> tuple[np.ndarray, np.ndarray]:
    """Checked frames as (n_cycles, n_rx, n_chirps, n_samples) (n_rx = 1 without receivers: a view) and the active
    chirps bool (n_cycles, n_chirps); one cycle's frames (no cycle axis) become a batch of one."""
    x = _check_frames(frames)
    lead = 1 if receivers else 0
    if x.ndim not in (2 + lead, 3 + lead):
        rx = "n_rx, " if receivers else ""
        hint = "; a receiver array's frames take receivers=True" if x.ndim == 4 and not receivers else ""
        raise ValueError(f"frames: expected shape ({rx}n_chirps, n_samples) or (n_cycles, {rx}n_chirps, n_samples), "
                         f"got {x.shape}{hint}")
    if x.ndim == 2 + lead:
        x = x[None]
    if not receivers:
        x = x[:, None]
    active = np.broadcast_to(np.atleast_2d(check_rho(rho, x.shape[2], x.shape[0])), (x.shape[0], x.shape[2]))
    return x, active


def _silent_powers(x: np.ndarray, active: np.ndarray) -> np.ndarray:
    """Bin powers |X_b|^2 of the silent chirps summed over the receivers, float64 (n_cycles, M, bins): x from
    `_cycles`, M = n_chirps / 2 silent chirps per cycle in chirp order."""
    m = x.shape[2] // 2
    silent = np.swapaxes(x, 1, 2)[~active].reshape(x.shape[0], m, x.shape[1], x.shape[-1])
    return _over_receivers(_bin_powers(silent), 2)


def _over_receivers(power: np.ndarray, axis: int) -> np.ndarray:
    """`power` summed over its receiver axis; with one receiver that axis dropped, a view (no pass over the data:
    the one-receiver tests cost what they did before arrays)."""
    return np.squeeze(power, axis) if power.shape[axis] == 1 else np.sum(power, axis=axis)


def gamma_threshold(pf: float, n_bins: int, n_rx: int) -> float:
    """The exact threshold of the max of n_bins i.i.d. Gamma(n_rx, 1): `spectral_threshold`'s closed form for
    n_rx = 1, `integrated_threshold` otherwise."""
    return spectral_threshold(pf, n_bins) if n_rx == 1 else integrated_threshold(pf, n_bins, n_rx)


def _bin_powers(frames: np.ndarray) -> np.ndarray:
    """|X_b|^2 over the bins with an exact Exp law: all bins for I/Q, bins 1..N/2-1 of the rfft for I-only."""
    n_s = frames.shape[-1]
    if np.iscomplexobj(frames):
        spec = scipy.fft.fft(frames, axis=-1)
    else:
        spec = scipy.fft.rfft(frames, axis=-1)[..., 1: (n_s - 1) // 2 + 1]   # drop DC and Nyquist (chi2(1))
    return spec.real.astype(np.float64) ** 2 + spec.imag.astype(np.float64) ** 2


def spectral_silent_test(frames, rho, sigma_n: float, *, pf: float = 1e-6, receivers: bool = False
                          ) -> SpectralResult:
    """Spectral silent-chirp test.

    frames  float32/64 | complex64/128 (n_cycles, n_chirps, n_samples), or (n_cycles, n_rx, n_chirps, n_samples)
            with receivers=True (either without its cycle axis for one cycle);  rho  (n_cycles, n_chirps) or
            (n_chirps,);  sigma_n noise RMS per sample (> 0, every receiver's);  pf  false-alarm probability per
            cycle (exact under white Gaussian noise)
    stat    max over silent chirps and tested bins of sum_r |X_{r,b}|^2 / (N_s sigma_n^2) (Gamma(n_rx, 1) per bin)
    """
    x, active = _cycles(frames, rho, receivers)
    if not sigma_n > 0:
        raise ValueError(f"sigma_n: must be > 0 for the spectral test, got {sigma_n!r}")
    _need_bins(x, "spectral")
    power = _silent_powers(x, active) / (x.shape[-1] * sigma_n ** 2)
    flat = power.reshape(x.shape[0], -1)
    idx = np.argmax(flat, axis=1)
    stat = flat[np.arange(x.shape[0]), idx]
    n_tested = flat.shape[1]
    thr = gamma_threshold(pf, n_tested, x.shape[1])
    stat = np.where(np.isnan(stat), np.inf, stat)
    return SpectralResult(stat, idx % power.shape[-1], thr, stat >= thr, n_tested, x.shape[1])


def integrated_threshold(pf: float, n_bins: int, n_summed: int) -> float:
    """t with P(max of n_bins i.i.d. Gamma(n_summed, 1) >= t) = pf, exactly (a sum of n_summed Exp(1) bin powers)."""
    if not 0 < pf < 1:
        raise ValueError(f"pf: must be in (0, 1), got {pf!r}")
    per_bin = -np.expm1(np.log1p(-pf) / n_bins)
    return float(stats.gamma.isf(per_bin, n_summed))


def integrated_silent_test(frames, rho, sigma_n: float, *, pf: float = 1e-6, receivers: bool = False
                           ) -> SpectralResult:
    """Non-coherent integration of the silent chirps' range spectra.

    frames, rho, sigma_n, pf, receivers  as `spectral_silent_test`
    stat    max over tested bins of sum over the M silent chirps (and the n_rx receivers) of |X_b|^2 / (N_s sigma_n^2)
            (Gamma(n_rx M, 1) per bin under white Gaussian noise); n_bins_tested = bins per chirp; threshold from
            `integrated_threshold`
    """
    x, active = _cycles(frames, rho, receivers)
    if not sigma_n > 0:
        raise ValueError(f"sigma_n: must be > 0 for the integrated test, got {sigma_n!r}")
    _need_bins(x, "integrated")
    n_s, m = x.shape[-1], x.shape[2] // 2
    power = np.sum(_silent_powers(x, active), axis=1) / (n_s * sigma_n ** 2)   # (cycles, bins)
    idx = np.argmax(power, axis=1)
    stat = power[np.arange(x.shape[0]), idx]
    thr = integrated_threshold(pf, power.shape[1], x.shape[1] * m)
    stat = np.where(np.isnan(stat), np.inf, stat)
    return SpectralResult(stat, idx, thr, stat >= thr, power.shape[1], x.shape[1])


def coherent_silent_test(frames, rho, sigma_n: float, *, pf: float = 1e-6, receivers: bool = False
                         ) -> SpectralResult:
    """The silent chirps' own range-Doppler map (Hann in range, zeros at the active chirps), summed over receivers.

    frames, rho, sigma_n, pf, receivers  as `spectral_silent_test`
    stat    max cell of the normalised map summed over the n_rx receivers' maps (Gamma(n_rx, 1) per cell under white
            Gaussian noise); peak_bin is the cell's flat index doppler * n_range_bins + range_bin; threshold t with
            P(Gamma(n_rx, 1) >= t) = pf / n_cells, ln(n_cells / pf) for one receiver (union bound: PF <= pf)
    """
    x, active = _cycles(frames, rho, receivers)
    if not 0 < pf < 1:
        raise ValueError(f"pf: must be in (0, 1), got {pf!r}")
    _need_bins(x, "coherent")
    n, n_rx = x.shape[:2]
    maps = rd_power(x.reshape(n * n_rx, *x.shape[2:]), np.repeat(~active, n_rx, axis=0), sigma_n)
    power = _over_receivers(maps.reshape(n, n_rx, -1), 1)
    idx = np.argmax(power, axis=1)
    stat = power[np.arange(n), idx]
    stat = np.where(np.isnan(stat), np.inf, stat)
    cells = power.shape[1]
    thr = float(np.log(cells / pf)) if n_rx == 1 else float(stats.gamma.isf(pf / cells, n_rx))
    return SpectralResult(stat, idx, thr, stat >= thr, cells, n_rx)


@dataclass(frozen=True)
class SpillResult:
    """stat float64 (n_cycles,): max over tested bins of the bin powers summed over the slots used, in units of the
    cycle's own threshold (alarm iff stat >= 1; 0 for a cycle without a silent slot after an active one);
    threshold float64 (n_cycles,): that threshold in noise-power units; n_slots int (n_cycles,): M, the silent slots
    after active ones (chirps 1..); first_sample int; alarm bool (n_cycles,); n_rx int: the receivers summed in
    every bin (Gamma(n_rx M, 1) under noise)."""

    stat: np.ndarray
    threshold: np.ndarray
    n_slots: np.ndarray
    first_sample: int
    alarm: np.ndarray
    n_rx: int = 1


def spill_test(frames, rho, sigma_n: float, first_sample: int, *, pf: float = 1e-6, receivers: bool = False
               ) -> SpillResult:
    """Energy still arriving in a silent slot after the longest visible round trip (a repeater's spill).

    frames  float32/64 | complex64/128 (n_cycles, n_chirps, n_samples), or (n_cycles, n_rx, n_chirps, n_samples)
            with receivers=True (either without its cycle axis for one cycle);  rho  (n_cycles, n_chirps) or
            (n_chirps,);  sigma_n noise RMS per sample (> 0, every receiver's);  first_sample  first sample of the
            window (0 .. n_samples - 4), from ``physics.max_visible_delay_s`` plus the IF filter's settling
            (``experiments/latency.py: window_start``)
    pf      false-alarm probability per cycle, exact under white Gaussian noise for any echo within the range
    Slot k (k >= 1) is used iff rho[k - 1] and not rho[k]; the chirp before chirp 0 belongs to another cycle. A bin's
    powers are summed over the used slots and the receivers.
    """
    return spill_tests(frames, rho, sigma_n, first_sample, [pf], receivers=receivers)[0]


def spill_tests(frames, rho, sigma_n: float, first_sample: int, pfs, *, receivers: bool = False
                ) -> list[SpillResult]:
    """`spill_test` at each false-alarm probability of `pfs`, from one pass over the frames. Only the used slots
    are transformed (about a quarter of the chirps with a balanced activation), and each cycle's are added in chirp
    order: the numbers of a sum over all its chirps with the others at zero, to the bit."""
    x, active = _cycles(frames, rho, receivers)
    if not sigma_n > 0:
        raise ValueError(f"sigma_n: must be > 0 for the spill test, got {sigma_n!r}")
    if not 0 <= first_sample <= x.shape[-1] - 4:
        raise ValueError(f"first_sample: must be in 0..{x.shape[-1] - 4}, got {first_sample}")
    for pf in pfs:
        if not 0 < pf < 1:
            raise ValueError(f"pf: must be in (0, 1), got {pf!r}")
    n_rx = x.shape[1]
    used = np.zeros(active.shape, dtype=bool)
    used[:, 1:] = active[:, :-1] & ~active[:, 1:]
    n_w = x.shape[-1] - first_sample
    cycle, slot = np.nonzero(used)                                           # cycle by cycle, in chirp order
    slots = np.swapaxes(x, 1, 2)[cycle, slot, :, first_sample:]             # (used slots, receivers, window)
    power = _over_receivers(_bin_powers(slots) / (n_w * sigma_n ** 2), 1)    # (used slots, bins)
    n_slots = used.sum(axis=1)
    # per cycle (batch-independent), the k-th used slot of every cycle at once: each cycle's sum in chirp order
    rank = np.arange(len(cycle)) - np.repeat(np.cumsum(n_slots) - n_slots, n_slots)
    summed = np.zeros((x.shape[0], power.shape[-1]))
    for k in range(int(n_slots.max(initial=0))):
        taken = rank == k
        summed[cycle[taken]] += power[taken]
    peak = summed.max(axis=1)
    peak = np.where(np.isnan(peak), np.inf, peak)
    some = n_slots > 0
    out = []
    for pf in pfs:
        thr = np.full(x.shape[0], np.inf)
        for m in np.unique(n_slots[some]).tolist():
            thr[n_slots == m] = integrated_threshold(pf, power.shape[-1], n_rx * m)
        with np.errstate(invalid="ignore"):
            stat = np.where(some, peak / thr, 0.0)
        out.append(SpillResult(stat, thr, n_slots, int(first_sample), stat >= 1.0, n_rx))
    return out


def calibrate_threshold(null_stats, pf: float) -> float:
    """Empirical (1 - pf) quantile of a statistic on attack-free cycles; needs about 10 / pf cycles or more."""
    s = np.sort(np.asarray(null_stats, dtype=np.float64))
    if s.size * pf < 10:
        raise ValueError(f"calibrate_threshold: {s.size} attack-free cycles are too few for pf = {pf} "
                         f"(need >= {int(np.ceil(10 / pf))})")
    return float(np.quantile(s, 1 - pf, method="higher"))


def silent_power_z(rms, rho, sigma_n: float, dof: int, *, n_rx: int = 1) -> np.ndarray:
    """Per-cycle z-score of the mean silent-chirp power: (mean ||R_k||_r^2 / sigma_n^2 - 1) sqrt(M n_rx nu / 2).

    rms  float (n_cycles, n_chirps): each chirp's RMS, over all its n_rx receivers' samples for an array
    (`chirp_rms(frames, receivers=True)`); dof  nu, real degrees of freedom per chirp of one receiver.
    Exactly standardised under white Gaussian noise (M n_rx nu u ~ chi2(M n_rx nu): the receivers' degrees of
    freedom add), ~N(0, 1)."""
    n_rx = receiver_count(n_rx)
    r = np.atleast_2d(np.asarray(rms, dtype=np.float64))
    active = np.broadcast_to(np.atleast_2d(check_rho(rho, r.shape[1], r.shape[0])), r.shape)
    m = r.shape[1] // 2
    u = np.sum(np.where(active, 0.0, r ** 2), axis=1) / m / sigma_n ** 2
    return (u - 1.0) * np.sqrt(m * dof * n_rx / 2.0)


def cusum_threshold(arl0_cycles: float, k: float = 0.5) -> float:
    """h giving an in-control average run length arl0 for a CUSUM of N(0,1) scores with allowance k (Siegmund):
    ARL0 ~ (exp(2 k b) - 2 k b - 1) / (2 k^2), b = h + 1.166."""
    if not arl0_cycles > 1:
        raise ValueError(f"arl0_cycles: must be > 1, got {arl0_cycles!r}")

    def f(h):
        b = 2 * k * (h + 1.166)
        return (np.expm1(b) - b) / (2 * k * k) - arl0_cycles

    return float(optimize.brentq(f, 0.0, 200.0))


def cusum_silent_power(z, *, k: float = 0.5, h: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """One-sided CUSUM S_t = max(0, S_{t-1} + z_t - k) over cycles; alarm when S_t >= h.

    z  float (n_cycles,) scores from `silent_power_z`; returns (S float64 (n_cycles,), alarm bool (n_cycles,)).
    """
    z = np.asarray(z, dtype=np.float64)
    s = np.empty_like(z)
    acc = 0.0
    for i, v in enumerate(z):
        acc = max(0.0, acc + v - k)
        s[i] = acc
    return s, s >= h
