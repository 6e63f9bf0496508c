"""What a DCA1000 capture holds, and whether the layout it is read with fits it.

inspect_codes(codes, scene, rho) on the decoded codes, int16 (cycles, n_chirps, n_rx, n_samples[, 2]):

  noise RMS per receiver, in codes (E|x|^2 = I^2 + Q^2 for complex data, as the scene's sigma_n):
    silent chirps (rho known):  sigma = sqrt(mean |x|^2 over the silent chirps' samples)  (what D0 divides by)
    robust floor (always):      sigma^2 = median_cells |RD|^2 / (ln 2 * n_samples * n_used_chirps)
                                white noise puts |RD|^2 of a cell exponentially about n_samples n_used sigma^2,
                                whose median is ln 2 times its mean; a few target cells do not move a median
  chirp RMS within a cycle (what D1 sees on this radar): over the active chirps (all chirps without rho) of
    each cycle and receiver, 20 log10(max R_k / min R_k) and max_k |R_k - Rbar| / (Rbar + sigma), the
    median over cycles
  strongest range-Doppler cells: |RD|^2 summed over receivers and cycles (silent chirps zeroed), local maxima
    (3 x 3, Doppler wrapping), each with its beat, range (range-Doppler coupling removed) and velocity by the
    estimators' convention (carav_stream/estimate/geometry.py: nu = 2 v T_c / lambda cycles per chirp,
    positive receding); real data searches range bins 1 .. n_samples/2 - 1 only

layout_warnings(...) on the raw words and the file size: the likely fix for a layout that does not fit.
  size      the file is not a whole number of cycles: the other layouts (lanes, real/complex, n_rx) that fit
  encoding  the codes fill the range (median |code| above a quarter of full scale) while the same words read
            with the other encoding cluster near zero (a median under an eighth of that): the other encoding
  lanes     the raw words' RMS by position in groups of eight differs by more than 10 dB (lanes that carry
            nothing, as a 4-lane capture's unused lanes do), or the receivers' RMS does: the other lane count
            or interleave, or another n_rx
  chirps    the active chirps' RMS within a cycle spread by more than 10 dB (median over cycles): chirps
            are cut at the wrong places (n_samples, n_rx or lanes), or rho is not this capture's (without rho
            every chirp counts as active, and a radar that silences chirps spreads them too: the text says so)

Cost: two FFTs over the capture's samples (scipy.fft) and a few passes; a 128 x 256 x 4-receiver real cycle
takes a few ms.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.fft
from scipy.ndimage import maximum_filter

from carav_stream.capture.dca1000 import Layout, signed_codes
from carav_stream.core.units import C_MPS

SPREAD_DB = 10.0       # receivers, lanes or active chirps further apart than this: the layout is doubted


def _power(codes: np.ndarray, complex_data: bool) -> np.ndarray:
    """|x|^2 per sample, float64 (..., n_samples)."""
    x = codes.astype(np.float64)
    return (x ** 2).sum(axis=-1) if complex_data else x ** 2


def _samples(codes: np.ndarray, complex_data: bool) -> np.ndarray:
    x = codes.astype(np.float64)
    return x[..., 0] + 1j * x[..., 1] if complex_data else x


def range_doppler(codes: np.ndarray, complex_data: bool, active: np.ndarray) -> np.ndarray:
    """|RD|^2 float64 (cycles, n_rx, n_chirps (Doppler bin), n_bins): FFT over fast time then over the chirps,
    silent chirps (active False, bool (cycles, n_chirps)) zeroed; real data keeps bins 0 .. n_samples/2."""
    x = _samples(codes, complex_data) * active[:, :, None, None]
    spec = scipy.fft.fft(x, axis=-1) if complex_data else scipy.fft.rfft(x, axis=-1)
    rd = scipy.fft.fft(spec, axis=1)
    return np.moveaxis(np.abs(rd) ** 2, 2, 1)


def inspect_codes(codes: np.ndarray, scene, rho: np.ndarray | None = None, top: int = 5) -> dict:
    """Noise RMS per receiver, chirp RMS spread and the strongest range-Doppler cells of decoded codes.

    codes int16 (cycles, n_chirps, n_rx, n_samples[, 2]); scene: fs_hz, slope_hz_per_s, fc_hz, t_chirp_s, iq;
    rho bool (cycles, n_chirps) or None. Plain types out (for JSON)."""
    complex_data = codes.ndim == 5
    n_cycles, n_chirps, n_rx, n_samples = codes.shape[:4]
    active = np.ones((n_cycles, n_chirps), bool) if rho is None else np.asarray(rho, bool)
    power = _power(codes, complex_data)                       # (cycles, chirps, rx, samples)
    chirp_rms = np.sqrt(power.mean(axis=-1))                  # (cycles, chirps, rx)
    rd = range_doppler(codes, complex_data, active)           # (cycles, rx, doppler, bins)
    bins = slice(0, None) if complex_data else slice(1, n_samples // 2)
    n_used = active.sum(axis=1)                               # active chirps per cycle
    floor = np.median(rd[..., bins] / (math.log(2) * n_samples * np.maximum(n_used, 1))[:, None, None, None],
                      axis=(0, 2, 3))
    noise = {"floor_codes": np.sqrt(floor).tolist()}
    silent = ~active
    if rho is not None and silent.any():
        noise["silent_chirps_codes"] = np.sqrt(power[silent].mean(axis=(0, 2))).tolist()
    sigma = np.asarray(noise.get("silent_chirps_codes", noise["floor_codes"]))
    spread, d1 = _chirp_spread(chirp_rms, active, sigma)
    return {"cycles": n_cycles, "n_rx": n_rx, "noise_rms": noise,
            "receiver_rms_codes": np.sqrt(power.mean(axis=(0, 1, 3))).tolist(),
            "chirp_rms_spread_db": spread.tolist(), "chirp_d1_max": d1.tolist(),
            "cells": _strongest(rd.sum(axis=(0, 1)), scene, complex_data, n_samples,
                                float(n_samples * n_used.sum() * floor.sum()), top)}


def _chirp_spread(chirp_rms: np.ndarray, active: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per receiver, the median over cycles of 20 log10(max/min) and of max |R_k - Rbar| / (Rbar + sigma) over
    the active chirps of a cycle."""
    r = np.where(active[:, :, None], chirp_rms, np.nan)       # (cycles, chirps, rx)
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = 20 * np.log10(np.nanmax(r, axis=1) / np.nanmin(r, axis=1))
        rbar = np.nanmean(r, axis=1)
        d1 = np.nanmax(np.abs(r - rbar[:, None]), axis=1) / (rbar + sigma)
    return np.median(spread, axis=0), np.median(d1, axis=0)


def _strongest(rd: np.ndarray, scene, complex_data: bool, n_samples: int, floor: float, top: int) -> list[dict]:
    """The `top` largest local maxima of a (doppler, bins) power map, with beat, range, velocity and their power
    above `floor`, the map's expected noise power per cell."""
    n_doppler = rd.shape[0]
    search = rd.copy()
    if not complex_data:
        search[:, 0] = search[:, n_samples // 2:] = -1.0      # DC and the Nyquist bin hold no range
    peaks = (search == maximum_filter(search, size=3, mode=("wrap", "nearest"))) & (search > 0)
    order = np.argsort(search[peaks])[::-1][:top]
    dop, rng = np.nonzero(peaks)
    wavelength = C_MPS / scene.fc_hz
    out = []
    for i in order:
        l, k = int(dop[i]), int(rng[i])
        nu = l / n_doppler if l <= n_doppler // 2 else l / n_doppler - 1.0
        velocity = nu * wavelength / (2.0 * scene.t_chirp_s)
        beat = k * scene.fs_hz / n_samples
        range_m = C_MPS / (2.0 * scene.slope_hz_per_s) * (beat - 2.0 * velocity / wavelength)
        out.append({"doppler_bin": l, "range_bin": k, "beat_hz": beat, "range_m": range_m,
                    "velocity_mps": velocity, "above_floor_db": 10 * math.log10(rd[l, k] / floor) if floor > 0
                    else math.inf})
    return out


# --------------------------------------------------------------------------------------------------- layouts

def fitting_layouts(size: int, layout: Layout) -> list[Layout]:
    """Other layouts (lanes, real/complex, n_rx) of the same chirps and samples that make `size` bytes a whole
    number of cycles (at least one)."""
    out = []
    for lanes in (2, 4):
        for complex_data in (False, True):
            for n_rx in (1, 2, 3, 4):
                try:
                    other = replace(layout, lanes=lanes, complex=complex_data, n_rx=n_rx)
                except ValueError:
                    continue
                if other != layout and size >= other.bytes_per_cycle and size % other.bytes_per_cycle == 0:
                    out.append(other)
    return out


def _name(layout: Layout) -> str:
    return f"lanes = {layout.lanes}, n_rx = {layout.n_rx}, {'complex' if layout.complex else 'real'}"


def layout_warnings(path: str, size: int, words: np.ndarray, layout: Layout, codes: np.ndarray,
                    rho: np.ndarray | None = None) -> list[str]:
    """Warnings, each with the likely fix, for a layout that does not fit a capture of `size` bytes whose first
    whole cycles are `words` (int16 as in the file) and decode to `codes` (cycles, n_chirps, n_rx, ...)."""
    out = []
    left = size % layout.bytes_per_cycle
    if left or size < layout.bytes_per_cycle:
        fits = fitting_layouts(size, layout)
        out.append(f"{path}: {size} bytes are not a whole number of cycles of {layout.describe()} "
                   f"({layout.bytes_per_cycle} bytes each; {left} left over)"
                   + (f"; these layouts fit: {'; '.join(_name(f) for f in fits)}" if fits else
                      "; no other lane count, n_rx or real/complex fits: check n_chirps and n_samples, or the "
                      "capture is truncated"))
    if words.size == 0:
        return out
    full = 2 ** (layout.adc_bits - 1)
    other = "offset_binary" if layout.encoding == "twos_complement" else "twos_complement"
    here = float(np.median(np.abs(signed_codes(words, layout.adc_bits, layout.encoding).astype(np.int32))))
    there = float(np.median(np.abs(signed_codes(words, layout.adc_bits, other).astype(np.int32))))
    if here > full / 4 and there < here / 8:
        out.append(f"{path}: read as {layout.encoding.replace('_', ' ')}, the codes fill the range (median |code| "
                   f"{here:.0f} of {full}) but read as {other.replace('_', ' ')} they cluster near zero (median "
                   f"{there:.0f}): probably encoding = \"{other}\"")
    groups = words[: words.size // 8 * 8].reshape(-1, 8).astype(np.float64)
    lane_rms = np.sqrt((groups ** 2).mean(axis=0))
    expected_empty = layout.lanes == 4 and layout.n_rx < 4
    if not expected_empty and lane_rms.max() > 0 and _spread_db(lane_rms) > SPREAD_DB:
        out.append(f"{path}: the words' RMS by position in groups of eight ({_list(lane_rms)}) differ by "
                   f"{_spread_db(lane_rms):.0f} dB: lanes carry unequal data, as a 4-lane capture with unused "
                   f"lanes does: probably lanes = 4 (and n_rx = the lanes that carry data)")
    rx_rms = np.sqrt(_power(codes, codes.ndim == 5).mean(axis=(0, 1, 3)))
    if rx_rms.size > 1 and rx_rms.max() > 0 and _spread_db(rx_rms) > SPREAD_DB:
        out.append(f"{path}: the receivers' RMS ({_list(rx_rms)} codes) differ by {_spread_db(rx_rms):.0f} dB: "
                   f"probably another lane count or interleave (lanes = {6 - layout.lanes}) or another n_rx")
    n = codes.shape[0] if rho is None else min(codes.shape[0], len(rho))
    active = np.ones(codes.shape[:2], bool) if rho is None else np.asarray(rho[:n], bool)
    chirp_rms = np.sqrt(_power(codes[:n], codes.ndim == 5).mean(axis=(2, 3)))     # (cycles, chirps)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(active, chirp_rms, np.nan)
        spread = float(np.median(20 * np.log10(np.nanmax(r, axis=1) / np.nanmin(r, axis=1))))
    if spread > SPREAD_DB:
        out.append(f"{path}: the {'active ' if rho is not None else ''}chirps' RMS within a cycle spread by "
                   f"{spread:.0f} dB (median over cycles): chirps are probably cut at the wrong places (check "
                   f"n_samples, n_rx and lanes)" + (", or the activation log is not this capture's"
                                                    if rho is not None else
                                                    ", or the radar silences chirps: give the activation log"))
    return out


def _spread_db(rms: np.ndarray) -> float:
    with np.errstate(divide="ignore"):
        return float(20 * np.log10(rms.max() / rms.min())) if rms.min() > 0 else math.inf


def _list(values: np.ndarray) -> str:
    return ", ".join(f"{v:.3g}" for v in values)
