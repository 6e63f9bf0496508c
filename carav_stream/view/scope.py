"""The scope and the spectrum of a tapped frame: one chirp of one receiver of the frame's latest cycle as time
samples, and the power spectrum of those samples in dB against frequency (the scene's sample rate), with the range
each beat frequency stands for on the ADC's and the channel's frames of an FMCW scene. Pure numpy and scipy: no
plotting, no sockets.

A tapped payload (runtime/port_tap.py) holds the last row of the frame's leading axis, one cycle:

    (1, n_chirps[, n_rx], n_samples[, 2])      radar frames: chirps, receivers if any, fast-time samples
                                               (int16 ADC codes of an I/Q scene end in an I, Q pair)

`layout` reads the axes: after the cycle, the last is fast time (the I, Q pair of integer codes taken off
first), the one before it the chirp and, when there are two, chirp then receiver (the capture's order). ADC
codes become samples in sqrt(W) at the ADC input (radar.adc.from_codes); samples of other streams are shown as
they are.

Spectrum: the periodogram of the samples with a Hann window, scaled as scipy.signal.periodogram's "spectrum"
(the power of a tone, whatever the window): P[k] = |sum_n w[n] x[n] e^(-2 pi i k n / N)|^2 / (sum_n w[n])^2,
doubled for real samples at the frequencies that fold their negative twin (0 < f < fs / 2), in dB (10 log10 P,
re 1 W for samples in sqrt(W)). A tone of amplitude A on a bin reads 10 log10(A^2) (complex) or 10 log10(A^2 / 2)
(real), its power. Frequencies: 0 .. fs / 2 for real samples; for complex ones -fs / 2 .. fs / 2, except on the
FMCW streams, whose I/Q beat runs 0 .. fs (FFT order, as the range-Doppler map reads it). Range there is the
beat's c f / (2 S), without Doppler correction (a moving target's beat reads 2 v / lambda x c / (2 S) further).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import get_window

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.adc import from_codes

RANGE_KINDS = frozenset({"adc_frame", "clean_frame", "rx"})   # the beat at the ADC: a frequency is a range
FLOOR_W = 1e-30     # power drawn for an empty bin (-300 dB): the log of zero is not a number to plot


@dataclass(frozen=True)
class Layout:
    """The axes of a tapped payload: chirps and receivers (0 when it has no such axis), fast-time samples, and
    whether its last axis is the I, Q pair of integer codes."""
    n_chirps: int
    n_rx: int
    n_samples: int
    iq_pair: bool


def layout(shape: tuple[int, ...], dtype: np.dtype, iq: bool) -> Layout | None:
    """The axes of a payload of `shape` and `dtype` (leading axis: the cycle), for a scene whose samples are I/Q
    when `iq`; None when it has no fast-time axis to show (header-only, one value per cycle, more than two axes
    between the cycle and fast time)."""
    dims = list(shape[1:])
    iq_pair = bool(iq and np.issubdtype(dtype, np.integer) and len(dims) >= 2 and dims[-1] == 2)
    if iq_pair:
        dims.pop()
    if not dims or dims[-1] == 0 or len(dims) > 3:
        return None
    middle = dims[:-1] + [0, 0]
    return Layout(n_chirps=middle[0], n_rx=middle[1], n_samples=dims[-1], iq_pair=iq_pair)


def trace(payload: np.ndarray, lay: Layout, scene: object, chirp: int = 0, rx: int = 0) -> np.ndarray:
    """The fast-time samples of `chirp` (of receiver `rx`) in the payload's last row: float or complex, (n_samples,);
    ADC codes as sqrt(W) at the ADC input. Indices beyond an axis are clipped to it."""
    row = np.asarray(payload)[-1]
    if lay.n_chirps:
        row = row[min(max(chirp, 0), lay.n_chirps - 1)]
    if lay.n_rx:
        row = row[min(max(rx, 0), lay.n_rx - 1)]
    if row.dtype == np.int16:
        return from_codes(scene, row[None])[0]
    if np.iscomplexobj(row):
        return row.astype(np.complex128)
    return row.astype(np.float64)


def spectrum_db(x: np.ndarray, fs_hz: float, fft_order: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies [Hz], power [dB]) of samples `x` at `fs_hz` (module docstring): real samples 0 .. fs / 2,
    complex ones -fs / 2 .. fs / 2, or 0 .. fs with `fft_order`."""
    x = np.asarray(x)
    n = x.shape[-1]
    w = get_window("hann", n, fftbins=True)
    scale = 1.0 / np.sum(w) ** 2
    if np.iscomplexobj(x):
        power = np.abs(np.fft.fft(x * w)) ** 2 * scale
        freqs = np.fft.fftfreq(n, 1.0 / fs_hz)
        if fft_order:
            freqs = np.arange(n) * fs_hz / n
        else:
            freqs, power = np.fft.fftshift(freqs), np.fft.fftshift(power)
    else:
        power = np.abs(np.fft.rfft(x * w)) ** 2 * scale
        power[1:-1 if n % 2 == 0 else None] *= 2.0     # every bin but DC and, when N is even, fs / 2
        freqs = np.fft.rfftfreq(n, 1.0 / fs_hz)
    return freqs, 10.0 * np.log10(np.maximum(power, FLOOR_W))


def time_axis_us(n_samples: int, fs_hz: float) -> np.ndarray:
    """Fast time of each sample from the first, in microseconds."""
    return np.arange(n_samples) * 1e6 / fs_hz


def beat_range_m(freqs_hz: np.ndarray, geometry: Geometry) -> np.ndarray:
    """The range [m] each beat frequency stands for, c f / (2 S), without Doppler correction."""
    return geometry.range_from_beat(freqs_hz)
