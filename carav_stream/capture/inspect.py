"""What a DCA1000 capture holds, and whether the layout it is read with fits it.

inspect_codes(codes, scene, rho) on the decoded codes, int16 (cycles, n_chirps, n_rx, n_samples[, 2]). The scene's
TDM schedule (tdm_schedule; one slot, one transmitter, when it has none) says which transmitter fired each chirp:
chirp k is slot j = k % S of loop l = k // S. The range-Doppler cube is the angle kernels' (carav_stream/estimate/
angle.py, virtual_cube): range FFT, then a Doppler FFT over the L loops of each slot, so that each virtual channel
(slot j heard on receiver r) is one transmitter's own chirps, sampled once a loop, and the velocity axis is
+-lambda / (4 S T_c), the scene's max_velocity_mps; an FFT over all the chirps would see the transmitters' alternation
as a Doppler modulation and split or alias a target off broadside. With one slot it is the FFT over the chirps.

  noise RMS per receiver, in codes (E|x|^2 = I^2 + Q^2 for complex data, as the scene's sigma_n):
    silent chirps (rho known):  sigma = sqrt(mean |x|^2 over the silent chirps' samples)  (what D0 divides by)
    robust floor (always):      sigma^2 = median_cells |RD|^2 / (ln 2 * n_samples * n_used_loops)
                                white noise puts |RD|^2 of a cell exponentially about n_samples n_used sigma^2,
                                whose median is ln 2 times its mean; a few target cells do not move a median
    with several slots, each also per slot (a transmitter that leaks into its receivers raises its slot's floor)
  chirp RMS within a cycle (what D1 sees on this radar): over the active chirps (all chirps without rho) of
    each cycle and receiver, 20 log10(max R_k / min R_k) and max_k |R_k - Rbar| / (Rbar + sigma), the
    median over cycles; with several slots also over each slot's chirps, and each slot's RMS (a transmitter
    whose chirps are much weaker, or silent, is a doubt: layout_warnings(n_slots=S) says so)
  strongest range-Doppler cells: |RD|^2 summed non-coherently over the virtual channels (slots x receivers) and
    cycles (silent chirps zeroed), local maxima (3 x 3, Doppler wrapping), each with its beat, range
    (range-Doppler coupling removed) and velocity by the estimators' convention (carav_stream/estimate/geometry.py:
    nu = 2 v T_c / lambda cycles per chirp, positive receding; Doppler bin d of the L-point FFT is wrap(d / L) / S
    cycles per chirp, d = L/2 read as +1/2); real data searches range bins 1 .. n_samples/2 - 1 only. When the
    scene places the capture's receivers (its n_rx is the capture's) and the virtual array has several elements,
    each cell also gets an azimuth: the beamscan (angle_spectrum) of its TDM-compensated virtual snapshot, power
    summed over cycles, at its peak on the grid sin(theta) = -1 + 2 k / n_angle (a grid value, not refined)

layout_warnings(...) on the raw words and the file size: the likely fix for a layout that does not fit.
  size      the file is not a whole number of cycles: the other layouts (lanes, real/complex, n_rx) that fit
  encoding  the codes fill the range (median |code| above a quarter of full scale) while the same words read
            with the other encoding cluster near zero (a median under an eighth of that): the other encoding
  lanes     the raw words' RMS by position in groups of eight differs by more than 10 dB (lanes that carry
            nothing, as a 4-lane capture's unused lanes do), or the receivers' RMS does: the other lane count
            or interleave, or another n_rx
  chirps    the active chirps' RMS within a cycle (within each TDM slot, given n_slots) spread by more than
            10 dB (median over cycles): chirps are cut at the wrong places (n_samples, n_rx or lanes), or rho is
            not this capture's (without rho every chirp counts as active, and a radar that silences chirps spreads
            them too: the text says so)
  slots     given n_slots > 1, the slots' RMS over their active chirps differ by more than 10 dB: a transmitter
            is weaker or does not fire (its txEnable, the scene's tdm_schedule)

Cost: two FFTs over the capture's samples (scipy.fft, complex64) and a few passes.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import maximum_filter

from carav_stream.capture.dca1000 import Layout, check_loops, signed_codes
from carav_stream.core.units import C_MPS

if TYPE_CHECKING:
    from carav_stream.estimate.virtual_array import VirtualArray

SPREAD_DB = 10.0       # receivers, lanes, slots or active chirps further apart than this: the layout is doubted


def _power(codes: np.ndarray, complex_data: bool) -> np.ndarray:
    """|x|^2 per sample, float64 (..., n_samples)."""
    x = codes.astype(np.float64)
    return (x ** 2).sum(axis=-1) if complex_data else x ** 2


def capture_array(scene, n_rx: int) -> tuple[VirtualArray, bool]:
    """The virtual array of a capture of n_rx receivers under the scene's TDM schedule, and whether the scene
    places those receivers (its rx_positions_wl has n_rx entries; else they stand at half-wave steps, which the
    power does not depend on, and no azimuth is given)."""
    # start-up time: the estimators' package is imported by the inspection only, not by dca1000_source's warnings
    from carav_stream.estimate.virtual_array import VirtualArray

    scene_array = VirtualArray.from_scene(scene)
    placed = scene_array.n_rx == n_rx
    rx = scene_array.rx_positions_wl if placed else tuple(0.5 * r for r in range(n_rx))
    return VirtualArray(rx, scene_array.tx_positions_wl, scene_array.tdm_schedule), placed


def virtual_channels(codes: np.ndarray, array: VirtualArray, active: np.ndarray) -> np.ndarray:
    """Z complex64 (cycles, n_slots * n_rx, n_loops, n_bins) of codes (cycles, n_chirps, n_rx, n_samples[, 2]):
    the angle kernels' virtual_cube (Doppler FFT over each slot's loops, TDM-compensated), silent chirps (active
    False, bool (cycles, n_chirps)) zeroed; real data keeps FFT bins 1 .. ceil(n_samples/2) - 1."""
    # start-up time: lazy, as in capture_array
    from carav_stream.estimate.angle import virtual_cube

    if codes.ndim == 5:
        x = codes[..., 0].astype(np.complex64)
        x.imag = codes[..., 1]
    else:
        x = codes.astype(np.float32)
    return virtual_cube(np.moveaxis(x, 2, 1), array, active)


def inspect_codes(codes: np.ndarray, scene, rho: np.ndarray | None = None, top: int = 5) -> dict:
    """Noise RMS per receiver, chirp RMS spread and the strongest range-Doppler cells of decoded codes.

    codes int16 (cycles, n_chirps, n_rx, n_samples[, 2]); scene: fs_hz, slope_hz_per_s, fc_hz, t_chirp_s, iq and,
    for a TDM radar, tdm_schedule (with tx_positions_wl, rx_positions_wl for the azimuth); rho bool (cycles,
    n_chirps) or None, active or silent by whole TDM loops (ValueError otherwise). Plain types out (for JSON)."""
    complex_data = codes.ndim == 5
    n_cycles, n_chirps, n_rx, n_samples = codes.shape[:4]
    array, placed = capture_array(scene, n_rx)
    s = array.n_slots
    active = np.ones((n_cycles, n_chirps), bool) if rho is None else np.asarray(rho, bool)
    check_loops(active, s, "rho")
    power = _power(codes, complex_data)                       # (cycles, chirps, rx, samples)
    chirp_rms = np.sqrt(power.mean(axis=-1))                  # (cycles, chirps, rx)
    z = virtual_channels(codes, array, active)                # (cycles, slots * rx, loops, bins)
    rd = (z.real.astype(np.float64) ** 2 + z.imag.astype(np.float64) ** 2)
    rd = rd.reshape(n_cycles, s, n_rx, *rd.shape[2:])          # (cycles, slots, rx, doppler, bins)
    n_used = active.reshape(n_cycles, -1, s).sum(axis=1)     # (cycles, slots): active loops of each slot
    per_cell = rd / (math.log(2) * n_samples * np.maximum(n_used, 1))[:, :, None, None, None]
    floor = np.median(np.moveaxis(per_cell, 2, 0).reshape(n_rx, -1), axis=1)
    noise = {"floor_codes": np.sqrt(floor).tolist()}
    silent = ~active
    if rho is not None and silent.any():
        noise["silent_chirps_codes"] = np.sqrt(power[silent].mean(axis=(0, 2))).tolist()
    sigma = np.asarray(noise.get("silent_chirps_codes", noise["floor_codes"]))
    spread, d1 = _chirp_spread(chirp_rms, active, sigma)
    out = {"cycles": n_cycles, "n_rx": n_rx, "noise_rms": noise,
           "receiver_rms_codes": np.sqrt(power.mean(axis=(0, 1, 3))).tolist(),
           "chirp_rms_spread_db": spread.tolist(), "chirp_d1_max": d1.tolist()}
    if s > 1:
        out |= {"n_slots": s, "tdm_schedule": list(array.tdm_schedule), "n_doppler": n_chirps // s,
                "max_velocity_mps": C_MPS / scene.fc_hz / (4.0 * scene.t_chirp_s * s)}
        out |= _per_slot(per_cell, power, chirp_rms, active, silent if rho is not None else None, sigma, s)
    cells = _strongest(rd.sum(axis=(0, 1, 2)), scene, complex_data, n_samples, s,
                       float(n_samples * n_used.sum() * floor.sum()), top)
    if placed and array.n_virtual > 1:
        _azimuths(cells, z, array, complex_data)
    out["cells"] = cells
    return out


def _per_slot(per_cell, power, chirp_rms, active, silent, sigma, s: int) -> dict:
    """The noise floor, the silent chirps' RMS, the active chirps' RMS and their spread within a cycle, per slot
    and receiver (lists of n_slots lists of n_rx)."""
    n_rx = power.shape[2]
    floor = np.median(np.moveaxis(per_cell, (1, 2), (0, 1)).reshape(s, n_rx, -1), axis=2)
    out = {"slot_noise_floor_codes": np.sqrt(floor).tolist()}
    slot_power = power.reshape(power.shape[0], -1, s, *power.shape[2:])         # (cycles, loops, slots, rx, samples)
    loops = active.reshape(active.shape[0], -1, s)
    if silent is not None and silent.any():
        out["slot_silent_chirps_codes"] = [np.sqrt(slot_power[:, :, j][~loops[:, :, j]].mean(axis=(0, 2))).tolist()
                                           for j in range(s)]
    rms, spread, d1 = [], [], []
    for j in range(s):
        act = loops[:, :, j]
        rms.append(np.sqrt(slot_power[:, :, j][act].mean(axis=(0, 2))) if act.any() else np.zeros(n_rx))
        sp, d = _chirp_spread(chirp_rms[:, j::s], act, sigma)
        spread.append(sp)
        d1.append(d)
    return {**out, "slot_rms_codes": np.array(rms).tolist(), "slot_chirp_rms_spread_db": np.array(spread).tolist(),
            "slot_chirp_d1_max": np.array(d1).tolist()}


def _chirp_spread(chirp_rms: np.ndarray, active: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per receiver, the median over cycles of 20 log10(max/min) and of max |R_k - Rbar| / (Rbar + sigma) over
    the active chirps of a cycle."""
    r = np.where(active[:, :, None], chirp_rms, np.nan)       # (cycles, chirps, rx)
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = 20 * np.log10(np.nanmax(r, axis=1) / np.nanmin(r, axis=1))
        rbar = np.nanmean(r, axis=1)
        d1 = np.nanmax(np.abs(r - rbar[:, None]), axis=1) / (rbar + sigma)
    return np.median(spread, axis=0), np.median(d1, axis=0)


def _strongest(rd: np.ndarray, scene, complex_data: bool, n_samples: int, n_slots: int, floor: float,
               top: int) -> list[dict]:
    """The `top` largest local maxima of a (doppler, bins) power map (real data: bins from FFT bin 1), with beat,
    range, velocity and their power above `floor`, the map's expected noise power per cell."""
    n_doppler = rd.shape[0]
    first = 0 if complex_data else 1
    peaks = (rd == maximum_filter(rd, size=3, mode=("wrap", "nearest"))) & (rd > 0)
    order = np.argsort(rd[peaks])[::-1][:top]
    dop, rng = np.nonzero(peaks)
    wavelength = C_MPS / scene.fc_hz
    out = []
    for i in order:
        l, k = int(dop[i]), int(rng[i])
        per_loop = l / n_doppler if l <= n_doppler // 2 else l / n_doppler - 1.0
        velocity = per_loop * wavelength / (2.0 * scene.t_chirp_s * n_slots)
        beat = (k + first) * scene.fs_hz / n_samples
        range_m = C_MPS / (2.0 * scene.slope_hz_per_s) * (beat - 2.0 * velocity / wavelength)
        out.append({"doppler_bin": l, "range_bin": k + first, "beat_hz": beat, "range_m": range_m,
                    "velocity_mps": velocity, "above_floor_db": 10 * math.log10(rd[l, k] / floor) if floor > 0
                    else math.inf})
    return out


def _azimuths(cells: list[dict], z: np.ndarray, array: VirtualArray, complex_data: bool) -> None:
    """Each cell's azimuth_deg: the beamscan peak of its snapshots over the virtual array, power summed over
    cycles (module docstring)."""
    # start-up time: lazy, as in capture_array
    from carav_stream.estimate.angle import angle_spectrum, sin_grid

    n_angle = max(64, 2 * array.n_virtual)
    grid = sin_grid(n_angle)
    first = 0 if complex_data else 1
    for cell in cells:
        spectrum = angle_spectrum(z[:, :, cell["doppler_bin"], cell["range_bin"] - first], array, n_angle)
        cell["azimuth_deg"] = math.degrees(math.asin(float(grid[int(np.argmax(spectrum.sum(axis=0)))])))


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
                    rho: np.ndarray | None = None, n_slots: int = 1) -> list[str]:
    """Warnings, each with the likely fix, for a layout that does not fit a capture of `size` bytes whose first
    whole cycles are `words` (int16 as in the file) and decode to `codes` (cycles, n_chirps, n_rx, ...); n_slots
    the scene's TDM slots (chirp k fired by slot k % n_slots)."""
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
    out += _chirp_warnings(path, _power(codes[:n], codes.ndim == 5).mean(axis=(2, 3)), active, n_slots,
                           rho is not None)
    return out


def _chirp_warnings(path: str, chirp_power: np.ndarray, active: np.ndarray, n_slots: int, logged: bool) -> list[str]:
    """The chirps' and the slots' warnings (module docstring) from the mean power of each chirp over its receivers'
    samples, float64 (cycles, n_chirps), and the active chirps."""
    out = []
    chirp_rms = np.sqrt(chirp_power)
    if n_slots > 1 and chirp_rms.shape[1] % n_slots == 0:
        slots = np.arange(chirp_rms.shape[1]) % n_slots
        slot_rms = np.array([math.sqrt(chirp_power[:, slots == j][active[:, slots == j]].mean())
                             if active[:, slots == j].any() else math.nan for j in range(n_slots)])
        spread = max(_cycle_spread_db(chirp_rms[:, j::n_slots], active[:, j::n_slots]) for j in range(n_slots))
        if np.isfinite(slot_rms).all() and slot_rms.max() > 0 and _spread_db(slot_rms) > SPREAD_DB:
            out.append(f"{path}: the TDM slots' RMS over their {'active ' if logged else ''}chirps "
                       f"({_list(slot_rms)} codes, slot 0 .. {n_slots - 1}) differ by {_spread_db(slot_rms):.0f} "
                       f"dB: a transmitter is much weaker or does not fire (check its txEnable in chirpCfg and "
                       f"channelCfg, and the scene's tdm_schedule)")
    else:
        spread = _cycle_spread_db(chirp_rms, active)
    if spread > SPREAD_DB:
        out.append(f"{path}: the {'active ' if logged else ''}chirps' RMS within a "
                   f"{'TDM slot of a ' if n_slots > 1 else ''}cycle spread by {spread:.0f} dB (median over "
                   f"cycles): chirps are probably cut at the wrong places (check n_samples, n_rx and lanes)"
                   + (", or the activation log is not this capture's" if logged else
                      ", or the radar silences chirps: give the activation log"))
    return out


def _cycle_spread_db(chirp_rms: np.ndarray, active: np.ndarray) -> float:
    """The median over cycles of 20 log10(max / min) of the active chirps' RMS (cycles, chirps) of a cycle."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(active, chirp_rms, np.nan)
        return float(np.median(20 * np.log10(np.nanmax(r, axis=1) / np.nanmin(r, axis=1))))


def _spread_db(rms: np.ndarray) -> float:
    with np.errstate(divide="ignore"):
        return float(20 * np.log10(rms.max() / rms.min())) if rms.min() > 0 else math.inf


def _list(values: np.ndarray) -> str:
    return ", ".join(f"{v:.3g}" for v in values)
