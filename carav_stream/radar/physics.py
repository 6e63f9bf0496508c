"""Signal physics shared by the channel and the attackers: dechirped echoes in both fidelities.

Dechirp convention (MATLAB ``dechirp``): y = x_ref * conj(x_rx). For an emitter whose signal reaches
the receiver with delay tau(t) = tau0 + alpha * t (alpha = 2 rdot / c for an echo, rdot / c one way),
the dechirped sample during the sweep is

    y(t) = A exp(j [2 pi fc tau + 2 pi S t' tau - pi S tau^2]),    t' = fast time in the chirp,

so the beat is S tau - f_D with f_D = -2 rdot / lambda (positive when closing): the beat is positive and
the Doppler enters with a minus sign. t = k t_chirp + t' is the time since the cycle start, which gives
the chirp-to-chirp phase progression 2 pi fc alpha t_chirp and the range migration (range-Doppler
coupling) for free. An I-only receiver digitises Re(y) (the I branch).

``beat`` fidelity evaluates closed forms at the ADC instants, time-faithfully: a replica delayed by tau occupies
its chirp slot from t' = tau on (``main``) and, because the emitter cannot stop before the victim's sweep has
reached it, spills into the first tau seconds of the next slot (``tail``), where the receiver's reference has
started its next sweep: the spill beats at S (tau - t_chirp) - f_D, far below the band unless tau is close to a
whole chirp. Both parts then pass the receiver's anti-alias (IF) filter, taken as ideal in this fidelity
(``if_band``: gain 1 inside the band, 0 outside), so a spill or an echo beyond the band is removed instead of
folding back. ``waveform`` fidelity builds the
baseband signals themselves on a grid ``waveform_oversample`` times finer than the ADC: the reference
chirp (which keeps sweeping on silent chirps), the emission as it left the emitter at t - tau(t) (gated
by the emitter's own on/off schedule: the victim's previous chirp arrives first, then the current
one), mixes them, low-pass filters with a linear-phase FIR (``if_filter``) and decimates to fs.
Mixer products beyond +-oversample*fs/2 alias on that grid: raise ``waveform_oversample`` for
interferers whose slope differs a lot from the victim's. A replica's part whose beat lies beyond the grid's Nyquist
rate (the AWR1642's spill beats near -2 GHz) is dropped rather than folded: the receiver's analog filter removes it.
Which beat a part has depends on the ramp the reference is on at that instant, so the previous chirp's echo is kept
up to the ramp reset (where it beats in band) and dropped after it.

The receiver's reference (LO) keeps sweeping on silent chirps: the transmitter is gated, the synthesiser and the
receive chain are not (paper, Section IV, step 4: acquisition in every chirp slot). So a silent slot is dechirped
exactly like an active one, and whatever arrives in it is judged against the same ramp.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from carav_stream.core.units import C_MPS
from carav_stream.radar.scene import IF_SETTLE_SAMPLES, Scene, Target

TWO_PI = 2.0 * np.pi
IQ_CENTRE = 0.4               # centre of the I/Q IF band, in units of fs


def fast_time_s(scene: Scene) -> np.ndarray:
    """ADC sampling instants within a chirp, float64 (n_samples,), seconds from the chirp start."""
    return scene.t_adc_start_s + np.arange(scene.n_samples) / scene.fs_hz


def chirp_start_s(scene: Scene) -> np.ndarray:
    """Start of each chirp since the cycle start, float64 (n_chirps,)."""
    return np.arange(scene.n_chirps) * scene.t_chirp_s


def echo_amplitude(scene: Scene, target: Target) -> float:
    """Amplitude A of the dechirped complex echo (A^2 = two-way received power, radar equation)."""
    p_w = scene.echo_power_w(target)
    return float(np.sqrt(p_w if scene.iq else 2.0 * p_w))


def beat_samples(scene: Scene, tau0_s: float, alpha: float, amplitude: float,
                 gate_from_s: float | None = None, analytic: bool = False) -> np.ndarray:
    """Closed-form dechirped samples of one delayed replica of the victim's chirp, for every chirp.

    tau(t) = tau0_s + alpha * t, t since the cycle start. ``gate_from_s``: samples with fast time
    below it are zero (a repeater that starts late). Returns complex128 (n_chirps, n_samples), or
    float64 Re(.) for an I-only scene (the quadrature part is never computed) unless ``analytic``, which
    asks for the complex samples whatever the scene (the analytic signal an array steers, radar/arrays.py).
    """
    tf = fast_time_s(scene)[None, :]
    tau = tau0_s + alpha * (chirp_start_s(scene)[:, None] + tf)
    s = scene.slope_hz_per_s
    phase = TWO_PI * scene.fc_hz * tau + TWO_PI * s * tf * tau - np.pi * s * tau * tau
    y = amplitude * (np.exp(1j * phase) if scene.iq or analytic else np.cos(phase))
    if gate_from_s is not None:
        y[:, tf[0] < gate_from_s] = 0
    return y


def if_band(scene: Scene) -> tuple[float, float]:
    """[low, high) of the receiver's IF band in Hz (the -6 dB edges of the waveform fidelity's FIR): [-fs/2, fs/2]
    for I-only (a real low-pass, so |beat| < fs/2), [-0.1 fs, 0.9 fs] for I/Q."""
    if scene.iq:
        return (IQ_CENTRE - 0.5) * scene.fs_hz, (IQ_CENTRE + 0.5) * scene.fs_hz
    return -scene.fs_hz / 2.0, scene.fs_hz / 2.0


def in_band(scene: Scene, beat_hz: float) -> bool:
    """Whether a tone at ``beat_hz`` passes the ideal IF filter of the beat fidelity (always, for a scene without
    one: ``if_filter = false``)."""
    if not scene.if_filter:
        return True
    low, high = if_band(scene)
    return low <= beat_hz < high


def max_visible_delay_s(scene: Scene) -> float:
    """The longest round trip whose echo (beat S tau) the receiver still passes, counting the waveform FIR's
    transition band (0.05 fs past the -6 dB edge): beyond it a replica's own slot holds nothing in band."""
    return (if_band(scene)[1] + 0.05 * scene.fs_hz) / scene.slope_hz_per_s


def fidelity_dependent_ranges_m(scene: Scene) -> tuple[tuple[float, float], ...]:
    """Ranges [from, to) in metres whose echo, or its spill into the next slot, beats within the waveform FIR's
    transition band (+-0.05 fs around an edge of the IF band, Doppler aside): there the waveform fidelity passes part
    of what the beat fidelity's ideal filter passes whole or removes, and results depend on the fidelity. Round trips
    up to one chirp period. A scene without the beat fidelity's filter (if_filter = false) folds every beat beyond
    the band instead, so there every range from the band's top on depends on the fidelity."""
    s, t_c, fs = scene.slope_hz_per_s, scene.t_chirp_s, scene.fs_hz
    spans = []
    for edge in if_band(scene):
        for offset in (0.0, t_c):                                   # the echo's own beat S tau, its spill S (tau - T_c)
            lo, hi = (edge - 0.05 * fs) / s + offset, (edge + 0.05 * fs) / s + offset
            lo, hi = max(lo, 0.0), min(hi, t_c)
            if lo < hi:
                spans.append([lo, hi])
    if not scene.if_filter:
        spans.append([max(0.0, (if_band(scene)[1] - 0.05 * fs) / s), t_c])
    spans.sort()
    merged: list[list[float]] = []
    for lo, hi in spans:
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return tuple((C_MPS * lo / 2.0, C_MPS * hi / 2.0) for lo, hi in merged)


def spill_window_start(scene: Scene) -> int:
    """First ADC sample of a slot that no echo the receiver passes reaches: after the longest visible round trip,
    plus the waveform FIR's half length (IF_SETTLE_SAMPLES) and one, so that no filtered edge reaches it either (the
    spill test's window, detect.opt_in.spill_test); 0 when the ADC starts later than that."""
    late = int(np.ceil((max_visible_delay_s(scene) - scene.t_adc_start_s) * scene.fs_hz))
    return max(0, late + IF_SETTLE_SAMPLES + 1)


def replica_beats_hz(scene: Scene, tau0_s: float, alpha: float) -> tuple[float, float]:
    """(main, spill) beat frequencies of a replica delayed by tau0_s at chirp 0, with the receiver's ramp sweeping:
    S tau + fc alpha in its own slot, S (tau - t_chirp) + fc alpha in the next (f_D = -fc alpha)."""
    f_dopp = scene.fc_hz * alpha
    return scene.slope_hz_per_s * tau0_s + f_dopp, scene.slope_hz_per_s * (tau0_s - scene.t_chirp_s) + f_dopp


def beat_replica(scene: Scene, tau0_s: float, alpha: float, amplitude: float,
                 gate_from_s: float | None = None, analytic: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Time-faithful beat-fidelity samples of a delayed replica of the victim's chirp (echo or spoof).

    Returns (main, tail) like :func:`waveform_replica`: ``main`` (n_chirps, n_samples) is chirp k's own
    emission, present from fast time tau(t) on and while the emission sweeps; ``tail`` is chirp k-1's emission
    still arriving before tau(t) (None when its beat lies outside the IF band, as for every echo within the
    radar's range: nothing of it reaches the ADC). ``main`` is the closed form of :func:`beat_samples`, zeroed
    before the echo arrives (and before ``gate_from_s``), and zero altogether when its beat is outside the band.
    complex128, or float64 for an I-only scene unless ``analytic`` (:func:`beat_samples`).
    """
    tf = fast_time_s(scene)[None, :]
    tau = tau0_s + alpha * (chirp_start_s(scene)[:, None] + tf)
    u_main = tf - tau
    f_main, f_tail = replica_beats_hz(scene, tau0_s, alpha)
    main = beat_samples(scene, tau0_s, alpha, amplitude, analytic=analytic)
    if in_band(scene, f_main):
        gate = (u_main >= 0) & (u_main < scene.t_sweep_s)
        if gate_from_s is not None:
            gate &= tf >= gate_from_s
        main *= gate
    else:
        main[...] = 0
    if not in_band(scene, f_tail):
        return main, None
    u_tail = u_main + scene.t_chirp_s
    gate = (u_main < 0) & (u_tail >= 0) & (u_tail < scene.t_sweep_s)    # gate_from_s delays chirp k's reply only
    s = scene.slope_hz_per_s
    ref = sweep_phase(scene, np.mod(tf, scene.t_chirp_s))
    phase = ref + TWO_PI * scene.fc_hz * tau - np.pi * s * np.clip(u_tail, 0, None) ** 2
    tail = amplitude * (np.exp(1j * phase) if scene.iq or analytic else np.cos(phase))
    tail *= gate
    return main, tail


# ---------------------------------------------------------------------------------------------
# waveform fidelity

@dataclass(frozen=True)
class WaveformGrid:
    """Oversampled fast-time grid around the ADC window, and the IF filter that brings it to fs."""

    t_fast_s: np.ndarray        # float64 (n_grid,), seconds since the chirp start (may be < 0)
    t_cycle_s: np.ndarray       # float64 (n_chirps, n_grid), seconds since the cycle start
    ref_phase: np.ndarray       # float64 (n_grid,), reference baseband phase theta(t')
    taps: np.ndarray            # float64 or complex128 (n_taps,), IF filter
    oversample: int


def sweep_phase(scene: Scene, u_s: np.ndarray) -> np.ndarray:
    """Baseband phase of the victim's chirp u_s seconds after a chirp start (LO parked at fc after
    the sweep). ``u_s`` must be in [0, t_chirp)."""
    s = scene.slope_hz_per_s
    return np.pi * s * np.minimum(u_s, scene.t_sweep_s) ** 2


@lru_cache(maxsize=16)
def waveform_grid(scene: Scene) -> WaveformGrid:
    r = scene.waveform_oversample
    fs_sim = r * scene.fs_hz
    n_taps = 2 * IF_SETTLE_SAMPLES * r + 1     # Hamming: transition about +-0.05 fs around each edge
    # I-only: real low-pass, -6 dB at fs/2. I/Q: complex band-pass [-0.1 fs, 0.9 fs] (-6 dB edges): one
    # fs wide, so nothing it passes aliases, and positive beats up to 0.9 fs stay unambiguous (as the
    # complex 1x IF mode of TI's AWR parts, whose IF bandwidth is 0.9 fs).
    import scipy.signal  # lazily, for start-up time: only the waveform fidelity needs it
    lp = scipy.signal.firwin(n_taps, scene.fs_hz / 2, fs=fs_sim)
    if scene.iq:
        n = np.arange(n_taps) - (n_taps - 1) / 2
        taps = lp * np.exp(2j * np.pi * IQ_CENTRE * scene.fs_hz * n / fs_sim)
    else:
        taps = lp
    half = (n_taps - 1) // 2
    i = np.arange(-half, r * (scene.n_samples - 1) + half + 1)
    t_fast = scene.t_adc_start_s + i / fs_sim
    t_cycle = chirp_start_s(scene)[:, None] + t_fast[None, :]
    u = np.mod(t_fast, scene.t_chirp_s)
    for a in (t_fast, t_cycle):
        a.setflags(write=False)
    return WaveformGrid(t_fast, t_cycle, sweep_phase(scene, u), taps, r)


def filter_decimate(scene: Scene, y: np.ndarray) -> np.ndarray:
    """IF filter then ADC sampling: (..., n_grid) -> (..., n_samples), same kind (real/complex)."""
    g = waveform_grid(scene)
    import scipy.signal
    out = scipy.signal.oaconvolve(y, g.taps.reshape((1,) * (y.ndim - 1) + (-1,)), mode="valid", axes=-1)
    return out[..., :: g.oversample]


def tone(scene: Scene, phase: np.ndarray, amplitude: np.ndarray | float, gate: np.ndarray, *,
         out: np.ndarray | None = None, analytic: bool = False) -> np.ndarray:
    """A gate exp(j phase), or its real part A gate cos(phase) for I-only unless ``analytic``; phase's shape.

    The product of :func:`mix`, from the mixer phase itself; ``out``: an array of that shape and dtype to write it
    into (returned). With a finite scalar A and finite phases the cosine (or the exponential) is evaluated only
    where the gate is on and the rest is 0, as cos(phase) A 0 is there (up to the sign of that zero, which no sum
    or product with a non-zero number shows): the same values, without evaluating the cosine (or the exponential)
    off the gate. Otherwise every sample is evaluated, so that a NaN or an infinity spreads as in the product
    written out.
    """
    complex_ = scene.iq or analytic
    y = np.empty(phase.shape, np.complex128 if complex_ else np.float64) if out is None else out
    if not (np.ndim(amplitude) == 0 and math.isfinite(amplitude)
            and math.isfinite(np.add.reduce(phase, axis=None))):
        if complex_:
            np.exp(np.multiply(1j, phase), out=y)
        else:
            np.cos(phase, out=y)
        y *= amplitude
        y *= gate
        return y
    y[...] = 0
    if complex_:
        np.multiply(1j, phase, out=y, where=gate)
        np.exp(y, out=y, where=gate)
    else:
        np.cos(phase, out=y, where=gate)
    np.multiply(y, amplitude, out=y, where=gate)
    return y


def mix(scene: Scene, emitted_phase: np.ndarray, carrier_phase: np.ndarray, amplitude: np.ndarray | float,
        gate: np.ndarray, analytic: bool = False) -> np.ndarray:
    """Mixer output ref * conj(rx) on the grid: A gate exp(j (theta_ref + carrier - theta_emitted)).

    ``carrier_phase`` is 2 pi fc tau (+ any carrier offset of the emitter). Real part for I-only unless ``analytic``.
    """
    g = waveform_grid(scene)
    return tone(scene, g.ref_phase + carrier_phase - emitted_phase, amplitude, gate, analytic=analytic)


def wrap_s(x: np.ndarray, period_s: float) -> np.ndarray:
    """``np.mod(x, period_s)`` for float64 ``x`` and a period T > 0: the same bits (a new array), without fmod.

    x mod T = x - n T with n = floor(x / T), a double (fmod is exact). Here n comes from the rounded quotient and
    T = T_hi + T_lo is split into two halves of 26 significant bits (Veltkamp), so that n T_hi and n T_lo are exact for
    n <= 2^20; with T in [2^E, 2^(E+1) - 2^(E-5)], x - n T_hi is exact as well (both multiples of 2^(E-52), their
    difference below 2^(E+1)), and so is the last subtraction wherever its result x - n T is a double. Where the
    quotient's rounding puts n one off, the result lies outside [0, T) and numpy's own mod is taken; so it is for
    x <= 0 (where numpy rounds fmod(x, T) + T), and for the whole array for NaNs, n > 2^20 or any other period.
    Multiplications and a floor cost far less than numpy's fmod over the waveform fidelity's grid.
    """
    t = float(period_s)
    if not 1e-290 < t < 1e290 or math.frexp(t)[0] > 1.0 - 2.0 ** -6:     # frexp: t = m 2^(E+1), m in [0.5, 1)
        return np.mod(x, period_s)
    n = np.multiply(x, 1.0 / t)
    np.floor(n, out=n)
    if not n.max(initial=0.0) <= 2.0 ** 20:
        return np.mod(x, period_s)
    c = t * 134217729.0                       # 2^27 + 1
    t_hi = c - (c - t)
    t_lo = t - t_hi
    u = np.multiply(n, t_hi)
    np.subtract(x, u, out=u)
    n *= t_lo
    u -= n
    bad = u < 0
    bad |= u >= t
    bad |= x <= 0
    if bad.any():
        u[bad] = np.mod(x[bad], period_s)
    return u


def waveform_replica(scene: Scene, tau0_s: float, alpha: float, amplitude: float,
                     gate_from_s: float | None = None, analytic: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Waveform-fidelity samples of a delayed replica of the victim's chirp (echo or spoof).

    Returns (main, tail), each (n_chirps, n_samples) complex128 (float64 I-only): ``main`` is what chirp k's own
    emission contributes, ``tail`` what chirp k-1's emission still contributes (its end arrives at the start of
    chirp k). The cycle's signal is rho[k] main[k] + rho[k-1] tail[k]. ``analytic``: complex for I-only too (the
    I-only receiver's real IF filter on the complex mixer output, whose real part is the I-only samples).
    """
    g = waveform_grid(scene)
    tau = tau0_s + alpha * g.t_cycle_s
    carrier = TWO_PI * scene.fc_hz * tau
    u_main = g.t_fast_s[None, :] - tau
    u_tail = u_main + scene.t_chirp_s
    gate_main = (u_main >= 0) & (u_main < scene.t_sweep_s)
    gate_tail = (u_main < 0) & (u_tail >= 0) & (u_tail < scene.t_sweep_s)
    if gate_from_s is not None:          # a late start delays chirp k's reply, not what is left of chirp k-1's
        gate_main &= g.t_fast_s[None, :] >= gate_from_s
    # A part beating beyond the grid's Nyquist rate would fold back on the grid: the analog filter removes it. The
    # beat depends on which ramp the reference is on: before the slot's start (t' < 0, the grid's lead-in) it is
    # still on the previous ramp, so chirp k-1's emission beats there at the main beat, in band, and its
    # truncation by the ramp reset reaches the first samples through the IF filter; from the slot's end on
    # (t' >= t_chirp) chirp k's emission beats at the spill beat.
    nyquist = g.oversample * scene.fs_hz / 2.0
    f_main, f_tail = replica_beats_hz(scene, tau0_s, alpha)
    before, after = g.t_fast_s < 0, g.t_fast_s >= scene.t_chirp_s
    keep_main, keep_tail = abs(f_main) < nyquist, abs(f_tail) < nyquist
    gate_main &= np.where(after, keep_tail, keep_main)[None, :]
    gate_tail &= np.where(before, keep_main, keep_tail)[None, :]
    s = scene.slope_hz_per_s
    main = mix(scene, np.pi * s * np.clip(u_main, 0, None) ** 2, carrier, amplitude, gate_main, analytic)
    tail = mix(scene, np.pi * s * np.clip(u_tail, 0, None) ** 2, carrier, amplitude, gate_tail, analytic)
    return filter_decimate(scene, main), filter_decimate(scene, tail)


# ---------------------------------------------------------------------------------------------
# target echoes, cached per (scene, fidelity)

@dataclass(frozen=True)
class EchoTemplates:
    """Noise-free echo of every target for a fully active cycle, at unit RCS fluctuation.

    main[t], tail[t]: complex64 (n_chirps, n_samples) (float32 I-only; at the receivers of an array,
    arrays.receiver_echoes: (n_rx, n_chirps, n_samples)): a target's echo of chirp k in slot k, and its spill from
    chirp k-1 into slot k. ``tail`` is None when no target spills anything into the band (beat
    fidelity: every target within the radar's range). main_sum / tail_sum: sum over targets (used when no target
    fluctuates).
    """

    main: tuple[np.ndarray, ...]
    tail: tuple[np.ndarray, ...] | None
    main_sum: np.ndarray
    tail_sum: np.ndarray | None


def target_delay(scene: Scene, target: Target) -> tuple[float, float]:
    """(tau0_s, alpha) of a target echo: tau(t) = 2 (R0 + rdot t) / c."""
    return 2.0 * target.range_m / C_MPS, 2.0 * scene.range_rate_mps(target) / C_MPS


@lru_cache(maxsize=16)
def echo_templates(scene: Scene, fidelity: str) -> EchoTemplates:
    dtype = np.complex64 if scene.iq else np.float32
    shape = (scene.n_chirps, scene.n_samples)
    mains, tails = [], []
    for t in scene.targets:
        tau0, alpha = target_delay(scene, t)
        amp = echo_amplitude(scene, t)
        m, tl = (beat_replica if fidelity == "beat" else waveform_replica)(scene, tau0, alpha, amp)
        mains.append(m.astype(dtype))
        tails.append(None if tl is None else tl.astype(dtype))
    return assemble_templates(mains, tails, shape, dtype, fidelity)


def assemble_templates(mains: list, tails: list, shape: tuple[int, ...], dtype, fidelity: str) -> EchoTemplates:
    """EchoTemplates of the targets' echoes (arrays of ``shape`` and ``dtype``, a tail None where nothing spills),
    with their sums, all read-only."""
    main_sum = np.sum(mains, axis=0, dtype=dtype) if mains else np.zeros(shape, dtype)
    if fidelity != "waveform" and all(tl is None for tl in tails):
        tails, tail_sum = None, None
    else:
        tails = [np.zeros(shape, dtype) if tl is None else tl for tl in tails]
        tail_sum = np.sum(tails, axis=0, dtype=dtype) if tails else np.zeros(shape, dtype)
    for a in (*mains, *(tails or ()), main_sum, *(() if tail_sum is None else (tail_sum,))):
        a.setflags(write=False)
    return EchoTemplates(tuple(mains), None if tails is None else tuple(tails), main_sum, tail_sum)
