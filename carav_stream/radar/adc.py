"""The receiver's ADC: quantisation to integer codes, clipping, and the step that turns codes back into samples.

    code = clip(rint(x / lsb), -2^(b-1), 2^(b-1) - 1),   lsb = adc_full_scale / 2^(b-1)   (I and Q separately)

`adc_codes` is what the ADC delivers (int16 codes, or the samples themselves for an ideal ADC), `from_codes`
turns codes into samples in sqrt(W), `adc_step` is the lsb a detector needs to read codes (defined here once).
Everything is elementwise after the cycle axis: frames of several receivers, (n_cycles, n_rx, n_chirps, n_samples),
are quantised receiver by receiver alike, and a cycle's clipped and non-finite counts are over all its receivers.
"""
from __future__ import annotations

import math

import numpy as np

from carav_stream.core.allocator import scratch
from carav_stream.radar.scene import Scene

__all__ = ["adc", "adc_codes", "adc_step", "from_codes", "output_noise_rms", "with_nonfinite"]


def adc_step(scene: Scene) -> float | None:
    """The lsb of the scene's ADC in sqrt(W), or None for an ADC that delivers samples (adc_bits 0 or > 16)."""
    if not 0 < scene.adc_bits <= 16:
        return None
    return scene.adc_full_scale / 2 ** (scene.adc_bits - 1)


def output_noise_rms(scene: Scene) -> float:
    """RMS per sample of the noise the ADC delivers: sqrt(sigma_n^2 + c lsb^2 / 12), c = 1 for I only and 2 for I/Q
    (the quantisation error of each real component, uniform over a step; exact in the limit sigma_n >> lsb). Near a
    loud echo the full scale, set above the echo, makes it matter: 1.087 x sigma_n for the table1 car at 5 m."""
    lsb = adc_step(scene)
    q = 0.0 if lsb is None else (2 if scene.iq else 1) * lsb ** 2 / 12
    return float(np.sqrt(scene.sigma_n ** 2 + q))


def adc(scene: Scene, rx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quantise to ``adc_bits`` over +-``adc_full_scale`` (mid-tread, saturating); I and Q separately.

    Returns (frames, clipped): frames same dtype and shape as rx, values on the ADC grid in the
    same units; clipped int64 (n_cycles,) = samples whose I or Q hit a rail. ``adc_bits = 0`` is an
    ideal ADC (a copy, no clipping). Equal to ``from_codes(scene, *adc_codes(scene, rx)[:1])``.
    """
    codes, clipped, nonfinite = adc_codes(scene, rx)
    return with_nonfinite(from_codes(scene, codes), rx, nonfinite), clipped


def with_nonfinite(frames: np.ndarray, rx: np.ndarray, nonfinite: np.ndarray) -> np.ndarray:
    """The ADC's samples with NaN where rx held a NaN/Inf (only cycles that had one are looked at)."""
    for i in np.flatnonzero(nonfinite):
        frames[i][~np.isfinite(rx[i])] = np.nan
    return frames


CHUNK_ELEMENTS = 1 << 18   # float32 elements of rx quantised at a time (1 MiB: the L2 cache of one core)


def adc_codes(scene: Scene, rx: np.ndarray, out: np.ndarray | None = None, *,
              add: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the ADC delivers: integer codes, int16 of rx's shape ((n_cycles, [n_rx,] n_chirps, n_samples)), or for
    I/Q that shape + (2,) with I then Q; clipped as in :func:`adc`; and nonfinite, int64
    (n_cycles,): samples whose I or Q was NaN or Inf at the ADC input (a simulation fault, not a signal: their
    code is 0, they are not counted as clipped, and the detector's RMS of such a cycle is NaN, so the
    detector judges it invalid). The scaling is float32 arithmetic, ``rint(x * float32(1 / lsb))``: a value
    within about 1e-4 LSB of a half code (near full scale) may round to the other neighbour than exact
    arithmetic would. An ideal ADC (``adc_bits = 0``) or one of more than 16 bits delivers a copy of rx
    instead (float32 | complex64; non-finite samples stay as they are and are counted). ``out``: an int16 array
    of the codes' shape to write them into (ignored for an ideal ADC). ``add``: a signal of rx's dtype that
    broadcasts to rx (the attack, (1 | n_cycles, [1 | n_rx,] 1 | n_chirps, n_samples)), added at the ADC input:
    the codes of ``rx + add`` without that sum's temporary. Work goes a few cycles at a time (``CHUNK_ELEMENTS``) in a
    reused scratch buffer, so the intermediate values stay in cache: the same numbers as one pass over the
    whole batch.

    Cost: numpy passes over a chunk for (rx + add), * 1/lsb, rint, the cast to int16, and a max and a min over
    the whole chunk that tell whether any of its cycles hit a rail or holds a NaN/Inf (only then are its cycles
    counted and fixed one by one). Chunks of a few cycles rather than one: fewer calls, fewer cache misses on the
    inputs. A compiled one-pass loop gives the same codes faster, on AVX-512 and AVX2 code alike, but numba's
    import and first call cost every process more CPU than the loop saves in a default run, so the ADC stays
    numpy. Measured: docs/bench/synth.md (the ADC stage), docs/bench/compiled.md (against numba).
    """
    n_cycles = rx.shape[0]
    if add is not None and (add.dtype != rx.dtype or add.ndim != rx.ndim
                            or any(d not in (1, r) for d, r in zip(add.shape, rx.shape))):
        raise ValueError(f"adc_codes: add must be {rx.dtype} broadcasting to {rx.shape}, got {add.dtype} {add.shape}")
    lsb = adc_step(scene)
    if lsb is None:
        return _ideal(rx, add)
    hi = np.float32(2 ** (scene.adc_bits - 1) - 1)
    lo = np.float32(-(2 ** (scene.adc_bits - 1)))
    scale = np.float32(1.0 / lsb)
    shape = rx.shape + (2,) if scene.iq else rx.shape
    if out is None:
        out = np.empty(shape, np.int16)
    elif out.dtype != np.int16 or out.shape != shape:
        raise ValueError(f"adc_codes: out must be int16 of shape {shape}, got {out.dtype} {out.shape}")
    per = math.prod(shape[1:])                                     # float32 values (I, Q interleaved) a cycle
    clipped = np.zeros(n_cycles, dtype=np.int64)
    nonfinite = np.zeros(n_cycles, dtype=np.int64)
    step = max(1, CHUNK_ELEMENTS // max(per, 1))
    buf = scratch("adc", min(step, n_cycles) * per, np.float32)
    for a in range(0, n_cycles, step):
        b = min(a + step, n_cycles)
        codes = buf[:(b - a) * per].reshape(b - a, per)
        if add is None:
            np.multiply(rx[a:b].reshape(b - a, -1).view(np.float32), scale, out=codes)   # complex64 -> I, Q
        else:
            np.add(rx[a:b], add if add.shape[0] == 1 else add[a:b], out=codes.view(rx.dtype).reshape(rx[a:b].shape))
            codes *= scale
        np.rint(codes, out=codes)
        _fix_rails(codes, lo, hi, scene.iq, clipped[a:b], nonfinite[a:b])
        np.copyto(out[a:b], codes.reshape((b - a,) + shape[1:]), casting="unsafe")
    return out, clipped, nonfinite


def _ideal(rx: np.ndarray, add: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An ideal ADC's output: a copy of rx (+ add), nothing clipped, the NaN/Inf samples of each cycle counted."""
    n_cycles = rx.shape[0]
    rx = rx.copy() if add is None else rx + add
    flat = rx.reshape(n_cycles, -1)
    nonfinite = np.zeros(n_cycles, dtype=np.int64)
    for i in np.flatnonzero(~np.isfinite(flat.sum(axis=1))):
        nonfinite[i] = np.count_nonzero(~np.isfinite(flat[i]))
    return rx, np.zeros(n_cycles, dtype=np.int64), nonfinite


def _fix_rails(codes: np.ndarray, lo: np.float32, hi: np.float32, iq: bool, clipped: np.ndarray,
               nonfinite: np.ndarray) -> None:
    """Clip a chunk's rounded codes (float32 (cycles, values a cycle), in place) to [lo, hi], NaN/Inf to 0, and
    count each cycle's clipped and non-finite samples into ``clipped`` and ``nonfinite`` (views of the chunk's
    cycles; an I/Q sample counts once)."""
    # two fast reductions over the whole chunk tell whether a cycle hit a rail or holds a NaN/Inf (NaN propagates
    # through max and min, and fails both tests); only then are its cycles looked at one by one, and only those
    # are counted and fixed
    top = np.maximum.reduce(codes, axis=None, initial=lo)
    bottom = np.minimum.reduce(codes, axis=None, initial=hi)
    if top <= hi and bottom >= lo:
        return
    top, bottom = codes.max(axis=1, initial=lo), codes.min(axis=1, initial=hi)
    for i in np.flatnonzero((top > hi) | (bottom < lo) | np.isnan(top)):
        row = codes[i]
        bad = ~np.isfinite(row)
        over = ((row > hi) | (row < lo)) & ~bad
        row[bad] = 0.0
        np.clip(row, lo, hi, out=row)
        if iq:   # a sample's I and Q flags share two bytes: any -> != 0
            over, bad = over.view(np.uint16), bad.view(np.uint16)
        clipped[i] = np.count_nonzero(over)
        nonfinite[i] = np.count_nonzero(bad)


def from_codes(scene: Scene, codes: np.ndarray) -> np.ndarray:
    """ADC codes (from :func:`adc_codes`) as samples in sqrt(W): float32 (I-only) or complex64 (I/Q),
    (n_cycles, [n_rx,] n_chirps, n_samples). Float input (an ideal ADC's) is returned as it is."""
    if codes.dtype != np.int16:
        return codes
    lsb = np.float32(adc_step(scene))
    x = np.multiply(codes, lsb, dtype=np.float32)
    return x.view(np.complex64)[..., 0] if scene.iq else x
