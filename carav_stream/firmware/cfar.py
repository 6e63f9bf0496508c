"""Target detection as radars do it: CFAR on the range-Doppler map of the active chirps (pure kernels).

The map is detect.rdmap.rd_power (Exp(1) per cell under white noise, whatever the activation pattern).

The tests. The training cells are taken along range, in the cell's own Doppler column, every third bin from
`gap` bins away on each side (gap a multiple of 3): cells 3 or more bins apart are independent, so the training
cells are independent of each other and of the cell under test for any activation pattern, and the design
false-alarm rate per cell is exact, also at the edges of the range axis, where the window keeps the cells that
exist and the threshold uses its own count n.

    CA-CFAR   T = alpha * mean(training),   P_fa = (1 + alpha / n)^(-n)           (Finn and Johnson)
    OS-CFAR   T = alpha * x_(k) (the k-th smallest of n),
              P_fa = prod_{i=0}^{k-1} (n - i) / (n - i + alpha)                    (Rohling)

Detections are cells above their threshold that are also the largest of their 3 x 3 (range x circular Doppler)
neighbourhood. A target's slow-time sidelobes on a half-silent cycle are only about 1/A below its peak and would
pass a CFAR test in their own right at high SNR: a detection weaker than a stronger one in the same or an adjacent
range bin by less than the cycle's worst sidelobe ratio (worst_sidelobe_ratio: the tone anywhere between two
Doppler bins, where a sparse pattern's sidelobes are not nulled; times SIDELOBE_MARGIN) is suppressed as its
sidelobe, and so is one within RANGE_SPREAD range bins (same or adjacent Doppler bin) weaker than the window's
range sidelobe level. Two real targets that close whose power ratio is within those ratios are reported as one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft  # scipy.optimize: loaded on first use (scipy's lazy submodules), not at import

__all__ = ["ca_alpha", "os_alpha", "cfar_threshold", "peak_sidelobe_ratio", "Detections",
           "detect_targets", "cells_to_range_velocity", "worst_sidelobe_ratio", "SIDELOBE_MARGIN"]

SIDELOBE_MARGIN = 2.0          # +3 dB over the worst sidelobe ratio (the noise adds to a sidelobe)
RANGE_SIDELOBE = 10 ** (-31.5 / 10)    # Hann's highest sidelobe; with a real echo's image, a few bins of spread
RANGE_SPREAD = 3                       # range bins around a stronger target where its range sidelobes may sit


def ca_alpha(pfa: float, n: int) -> float:
    """CA-CFAR multiplier for n exponential training cells: (1 + alpha/n)^-n = pfa."""
    _check_pfa(pfa)
    return float(n * np.expm1(-np.log(pfa) / n))


def os_alpha(pfa: float, n: int, k: int) -> float:
    """OS-CFAR multiplier for the k-th smallest of n exponential training cells: prod (n-i)/(n-i+alpha) = pfa."""
    _check_pfa(pfa)
    if not 1 <= k <= n:
        raise ValueError(f"k: must be in 1..{n}, got {k}")
    i = np.arange(k)

    def f(alpha):
        return float(np.sum(np.log(n - i) - np.log(n - i + alpha)) - np.log(pfa))

    hi = 1.0
    while f(hi) > 0:
        hi *= 2
    return float(scipy.optimize.brentq(f, 0.0, hi, xtol=1e-12, rtol=1e-12))


def _check_pfa(pfa: float) -> None:
    if not 0 < pfa < 1:
        raise ValueError(f"pfa: must be in (0, 1), got {pfa!r}")


STRIDE = 3          # Hann-windowed bins this far apart are independent
CHUNK_CELLS = 8_000_000


def _windows(n_range: int, gap: int, train: int) -> tuple[np.ndarray, np.ndarray]:
    """For every range bin, the indices of its training cells (padded with -1) and their count."""
    j = np.arange(n_range)
    side = gap + STRIDE * np.arange(train)
    offsets = np.concatenate([-side[::-1], side])
    idx = j[:, None] + offsets[None, :]
    idx = np.where((idx >= 0) & (idx < n_range), idx, -1)
    return idx, np.sum(idx >= 0, axis=1)


def _training_sums(p: np.ndarray, gap: int, train: int) -> np.ndarray:
    """Sum of every cell's training cells (every third bin from `gap` on, `train` per side, cells beyond the axis
    counting 0), from running sums with stride 3 (R[i] = p[i] + R[i - 3]): a few passes over the map whatever
    `train` is. The running sums are float64, so a weak cell beside a strong target keeps its own digits."""
    k = p.shape[-1]
    pad = gap + STRIDE * (train - 1)              # a multiple of 3: the residue classes keep their alignment
    width = -(-(k + 2 * pad) // STRIDE) * STRIDE + STRIDE
    runs = np.zeros(p.shape[:-1] + (width,))
    runs[..., STRIDE + pad: STRIDE + pad + k] = p  # STRIDE leading zeros: R[s + 3 train] - R[s] is a window
    folded = runs.reshape(p.shape[:-1] + (width // STRIDE, STRIDE))
    np.cumsum(folded, axis=-2, out=folded)
    span = STRIDE * train
    right = 2 * pad - STRIDE * (train - 1)        # the left window starts at cell j - pad, the right one at j + gap
    total = runs[..., span: span + k] - runs[..., :k]
    total += runs[..., right + span: right + span + k] - runs[..., right: right + k]
    return total.astype(p.dtype, copy=False)


def cfar_threshold(power: np.ndarray, *, pfa: float, gap: int = 3, train: int = 8, kind: str = "ca",
                   os_rank: float = 0.75) -> np.ndarray:
    """Threshold per cell along the last axis (range), same shape as power.

    gap     offset of the nearest training cell (a multiple of 3: the cells between are guard cells)
    train   training cells on each side, every third bin; kind "ca" or "os"; os_rank: k = ceil(os_rank n)
    """
    if kind not in ("ca", "os"):
        raise ValueError(f"kind: expected 'ca' or 'os', got {kind!r}")
    if gap < STRIDE or gap % STRIDE or train < 1:
        raise ValueError(f"gap must be a positive multiple of {STRIDE} and train >= 1, got {gap}, {train}")
    p = np.asarray(power)
    p = p if p.dtype in (np.float32, np.float64) else p.astype(np.float64)
    idx, counts = _windows(p.shape[-1], gap, train)
    if counts.min() < 1:
        raise ValueError(f"range axis of {p.shape[-1]} bins is too short for gap {gap}")
    if kind == "ca":
        alpha = np.array([ca_alpha(pfa, int(n)) for n in counts])
        return _training_sums(p, gap, train) * (alpha / counts)
    flat = p.reshape(-1, p.shape[-1])
    out = np.empty_like(flat)
    rows = max(1, CHUNK_CELLS // (p.shape[-1] * idx.shape[1]))       # bounded memory for the gathered windows
    for n in np.unique(counts):                       # one multiplier per window size (edges have fewer cells)
        cols = np.nonzero(counts == n)[0]
        take, valid = np.where(idx[cols] >= 0, idx[cols], 0), idx[cols] >= 0
        k = max(1, int(np.ceil(os_rank * n)))
        alpha = os_alpha(pfa, int(n), k)
        whole = valid.all()                           # the cells away from the edges: every window full
        for r0 in range(0, flat.shape[0], rows):
            cells = flat[r0: r0 + rows][:, take]                           # (rows, len(cols), 2 train): a copy
            if not whole:
                cells[:, ~valid] = np.inf
            cells.partition(k - 1, axis=-1)                                # in place: the copy is ours
            out[r0: r0 + rows, cols] = alpha * cells[..., k - 1]
    return out.reshape(p.shape)


def peak_sidelobe_ratio(rho) -> np.ndarray:
    """Largest slow-time sidelobe over the peak, per cycle: max_{l != 0} |sum_active e^{-j 2 pi l m / M}|^2 / A^2."""
    r = np.asarray(rho, dtype=np.float64)
    pattern = np.abs(scipy.fft.fft(r, axis=-1)) ** 2
    return np.max(pattern[:, 1:], axis=-1) / pattern[:, 0]


OFF_GRID_STEPS = 8    # Doppler offsets of a tone from its nearest bin looked at: 0, 1/8, ..., 1/2 bin


def worst_sidelobe_ratio(rho) -> np.ndarray:
    """Largest slow-time sidelobe over the peak cell for a tone anywhere between two Doppler bins, per cycle:
    max over offsets d in [0, 1/2] bin and cells l with |l| >= 2 of |P(l - d)|^2 / |P(-d)|^2, where
    P(u) = sum_active exp(-j 2 pi u m / M). Off the grid a sparse pattern's sidelobes are not nulled: on
    half-silent cycles they reach about 3 times the on-grid peak_sidelobe_ratio (median -7 dB at M = 64)."""
    r = np.asarray(rho, dtype=np.float64)
    m = r.shape[-1]
    fine = np.abs(scipy.fft.fft(r, n=OFF_GRID_STEPS * m, axis=-1)) ** 2
    cells = np.arange(m)
    worst = np.zeros(r.shape[0])
    for step in range(OFF_GRID_STEPS // 2 + 1):
        pattern = fine[:, (OFF_GRID_STEPS * cells - step) % (OFF_GRID_STEPS * m)]   # cell l for offset step/8
        worst = np.maximum(worst, pattern[:, 2: m - 1].max(axis=1) / pattern[:, 0])
    return worst


@dataclass(frozen=True)
class Detections:
    """Targets found per cycle, strongest first; NaN / -1 beyond n_found.

    doppler_bin, range_bin  int64 (C, K)    cells of the map (range bin j is FFT bin j, or j + 1 for I-only)
    power                   float64 (C, K)  normalised cell power (the SNR after integration, linear)
    snr_db                  float64 (C, K)  10 log10(power - 1): the estimated SNR after integration
    n_found                 int64 (C,)
    """

    doppler_bin: np.ndarray
    range_bin: np.ndarray
    power: np.ndarray
    snr_db: np.ndarray
    n_found: np.ndarray


def detect_targets(power: np.ndarray, rho, *, pfa: float = 1e-6, gap: int = 3, train: int = 8,
                   kind: str = "ca", max_targets: int = 8) -> Detections:
    """CFAR detections on normalised maps (rd_power), local maxima only, sidelobes of stronger targets removed."""
    p = np.asarray(power)
    p = p if p.dtype in (np.float32, np.float64) else p.astype(np.float64)
    c, m, k = p.shape
    hit = p > cfar_threshold(p, pfa=pfa, gap=gap, train=train, kind=kind)
    cs, ls_all, ks_all = np.nonzero(hit)        # few cells pass: the local-maximum test looks at those alone
    value = p[cs, ls_all, ks_all]
    local = np.ones(cs.size, dtype=bool)
    for dl in (-1, 0, 1):                       # Doppler is circular, range is not
        for dk in (-1, 0, 1):
            if dl or dk:
                kk = ks_all + dk
                inside = (kk >= 0) & (kk < k)
                local &= ~inside | (value >= p[cs, (ls_all + dl) % m, np.clip(kk, 0, k - 1)])
    cs, ls_all, ks_all = cs[local], ls_all[local], ks_all[local]
    bounds = np.searchsorted(cs, np.arange(c + 1))
    psl = worst_sidelobe_ratio(rho) * SIDELOBE_MARGIN
    out_l = np.full((c, max_targets), -1, np.int64)
    out_k = np.full((c, max_targets), -1, np.int64)
    out_p = np.full((c, max_targets), np.nan)
    n_found = np.zeros(c, np.int64)
    for ci in range(c):
        ls, ks = ls_all[bounds[ci]: bounds[ci + 1]], ks_all[bounds[ci]: bounds[ci + 1]]
        if ls.size > 1:   # the strongest is always kept: drop its sidelobes at once (the loop would, one by one)
            pw, top = p[ci, ls, ks], int(np.argmax(p[ci, ls, ks]))
            dk, dl = np.abs(ks - ks[top]), (ls - ls[top]) % m
            side = (((dk <= 1) & (pw < pw[top] * psl[ci]))
                    | ((dk <= RANGE_SPREAD) & np.isin(dl, (0, 1, m - 1))
                       & (pw < pw[top] * RANGE_SIDELOBE * SIDELOBE_MARGIN)))
            side[top] = False
            ls, ks = ls[~side], ks[~side]
        order = np.argsort(-p[ci, ls, ks], kind="stable")
        kept: list[tuple[int, int, float]] = []
        for i in order:
            l_, k_, pw = int(ls[i]), int(ks[i]), float(p[ci, ls[i], ks[i]])
            if any((abs(k_ - k2) <= 1 and pw < p2 * psl[ci])             # a slow-time sidelobe of a stronger one
                   or (abs(k_ - k2) <= RANGE_SPREAD and (l_ - l2) % m in (0, 1, m - 1)
                       and pw < p2 * RANGE_SIDELOBE * SIDELOBE_MARGIN)        # one of its range sidelobes
                   for l2, k2, p2 in kept):
                continue
            kept.append((l_, k_, pw))
            if len(kept) == max_targets:
                break
        n_found[ci] = len(kept)
        for j, (l_, k_, pw) in enumerate(kept):
            out_l[ci, j], out_k[ci, j], out_p[ci, j] = l_, k_, pw
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = 10 * np.log10(np.maximum(out_p - 1.0, 1e-12))
    return Detections(out_l, out_k, out_p, np.where(np.isnan(out_p), np.nan, snr), n_found)


def cells_to_range_velocity(det: Detections, geometry, n_chirps: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid range [m] (coupling removed) and radial velocity [m/s] of each detection (NaN where none).

    Doppler bin l is nu = l / M cycles per chirp, wrapped into [-1/2, 1/2); range bin j is beat (j [+ 1]) fs / N.
    """
    ok = det.range_bin >= 0
    nu = np.where(ok, det.doppler_bin, 0) / n_chirps
    nu = nu - np.floor(nu + 0.5)
    v = geometry.velocity_from_slow_freq(nu)
    fft_bin = np.where(ok, det.range_bin, 0) + (0 if geometry.iq else 1)
    beat = fft_bin * geometry.fs_hz / geometry.n_samples
    if geometry.iq:
        beat = np.where(fft_bin >= geometry.n_samples / 2, beat - geometry.fs_hz, beat)   # negative beats
    r = geometry.range_from_beat(beat, v)
    return np.where(ok, r, np.nan), np.where(ok, v, np.nan)
