"""estimate() and refine_at(): the steps every method shares around its own (the package docstring has them in
order), and the results in physical units."""
from __future__ import annotations

import numpy as np

from carav_stream.estimate import spectral
from carav_stream.estimate.estimators import _grid, _onset
from carav_stream.estimate.estimators._common import Chirps, Estimates, check_inputs, demod_slow, normalise
from carav_stream.estimate.estimators._method import Method
from carav_stream.estimate.estimators._registry import DEFAULT_METHOD, method_named
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.migration import refine_walking


def estimate(frames, rho, geometry: Geometry, *, method: str = DEFAULT_METHOD, n_targets: int | None = 1,
             max_targets: int = 4, criterion: str = "mdl", zeropad: int = 8, music_length: int | None = None,
             n_newton: int = 1, couple: bool = True, max_speed_mps: float = 0.0,
             lsb: float | None = None) -> Estimates:
    """Range and velocity of up to n_targets targets per cycle from the active chirps.

    frames        (n_cycles, n_chirps, n_samples) complex64 (geometry.iq) or float32 ADC samples
    rho           bool (n_cycles, n_chirps): chirps that transmitted in each cycle
    geometry      Geometry of the waveform
    method        one of METHODS
    n_targets     targets per cycle, or None to estimate it per cycle with `criterion` ('mdl' | 'aic'),
                  capped at max_targets (output width = largest estimate, at least 1)
    zeropad       fast-time zero-padding factor of fft_zeropad
    music_length  MUSIC subvector length L (default N // 4 for music, min(N // 4, 32) for root_music)
    n_newton      Newton steps per refinement (ml, and the Doppler stage of music / root_music)
    couple        remove the range-Doppler coupling from range_m (beat_hz is always the raw beat)
    max_speed_mps > 0: range migration compensated: the fft_peak cells of the strongest maxima, each refined along
                  its range walk (refine_at), velocities unaliased within +-max_speed_mps (method ignored)
    lsb           the ADC's step: frames are then its int16 codes (I/Q: a last axis of 2, I then Q), the samples
                  code * lsb (radar.adc.from_codes), converted for the active chirps only; the same result
    Returns Estimates; raises ValueError/TypeError naming the bad argument.
    """
    if max_speed_mps > 0:
        cells = estimate(frames, rho, geometry, method="fft_peak", n_targets=n_targets, max_targets=max_targets,
                         criterion=criterion, couple=False, lsb=lsb)
        return refine_at(frames, rho, geometry, cells.beat_hz / geometry.fs_hz,
                         geometry.slow_freq_from_velocity(cells.velocity_mps, sample=(geometry.n_samples - 1) / 2.0),
                         couple=couple,
                         max_speed_mps=max_speed_mps, lsb=lsb)
    chosen = method_named(method)
    frames, rho = check_inputs(frames, rho, geometry, lsb)
    if n_targets is not None and (int(n_targets) != n_targets or n_targets < 1):
        raise ValueError(f"estimate: n_targets must be a positive integer or None, got {n_targets!r}")
    if int(zeropad) != zeropad or zeropad < 1:
        raise ValueError(f"estimate: zeropad must be a positive integer, got {zeropad!r}")
    iq = geometry.iq
    chirps = Chirps.of(rho)
    x, scale, valid = normalise(frames, chirps, lsb)  # (C, A, N): the active chirps only

    if n_targets is None:
        order = np.where(valid, _grid.estimate_order(x, chirps, criterion, max_targets, iq), 0)
        width = max(int(order.max(initial=0)), 1)
    else:
        width = int(n_targets)
        order = np.where(valid, width, 0)
    options = {"n_newton": n_newton, "music_length": music_length, "iq": iq}
    if width == 1:
        f, nu, amp = _one_target(x, chirps, chosen, zeropad, geometry, options)
    else:
        f, nu, amp = _one_by_one(x, chirps, chosen, width, zeropad, geometry, options)
    found = np.arange(width)[None, :] < order[:, None]
    return _estimates(f, nu, amp, found, scale, chirps, geometry, chosen, couple)


def _one_target(x, chirps: Chirps, method: Method, zeropad: int, geometry: Geometry, options: dict):
    """Strongest target of every cycle from the compacted x (C, A, N): (f, nu, amp) each (C, 1); f
    [cycles/sample], nu [cycles/chirp], amp the positive-frequency tone amplitude per sample (normalised units).
    `options`: the keywords of Method.refine but the onset, which the start's beat gives (_onset)."""
    n_samp = x.shape[-1]
    range_pad, doppler_pad = method.padding(zeropad)
    nr = n_samp * range_pad
    md = chirps.n_chirps * doppler_pad
    # range FFT of the active chirps only (the silent ones are zero)
    spec = _grid.range_spectra(x, options["iq"], nr)
    l0, k0 = _grid.search(spec, chirps, md, options["iq"])  # (C, 1) Doppler and range bins
    f, nu, peak = method.locate(spec, chirps, l0, k0, n_samp, nr, md)
    amp = peak / (n_samp * np.maximum(chirps.count, 1))[:, None]
    if method.refine is not None:
        f, nu, amp = method.refine(x, chirps, f, nu, onset=_onset.onsets(f, nu, geometry), **options)
    return f, nu, amp


def _one_by_one(x, chirps: Chirps, method: Method, width: int, zeropad: int, geometry: Geometry, options: dict):
    """(f, nu, amp), each (C, width), of the `width` strongest targets: RELAX-style sequential search, the
    strongest target first, removed from the data before the next search (its echo from its onset on: its range
    and Doppler sidelobes -- high for a sparse active set -- would otherwise win), then the method's joint
    refinement of all targets with the others cancelled."""
    n_cycles, n_samp = x.shape[0], x.shape[-1]
    n_chirps, iq = chirps.n_chirps, options["iq"]
    f = np.zeros((n_cycles, width))
    nu = np.zeros((n_cycles, width))
    amp = np.zeros((n_cycles, width))
    resid = x.copy()
    n_act = np.maximum(chirps.count, 1)
    for k in range(width):
        fk, nuk, _ = _one_target(resid, chirps, method, zeropad, geometry, options)
        f[:, k], nu[:, k] = fk[:, 0], nuk[:, 0]
        onset = _onset.onsets(f[:, k], nu[:, k], geometry)
        slow = spectral.phasor(nu[:, k], n_chirps) * chirps.rho
        read = _onset.gates(onset.read, n_samp)
        alpha = (demod_slow(resid, chirps, f[:, k], read) * slow).sum(axis=1) / ((n_samp - onset.read) * n_act)
        amp[:, k] = np.abs(alpha)                                                                 # alpha e^{+j..}
        tone = (alpha[:, None] * chirps.gather(slow.conj()))[:, :, None] * \
            (spectral.phasor(f[:, k], n_samp, +1.0) * _onset.gates(onset.echo, n_samp))[:, None, :]
        resid = resid - (tone if iq else 2.0 * tone.real).astype(resid.dtype)  # real: a e^{..} + conj
    if method.refine is not None:
        f, nu, amp = method.refine(x, chirps, f, nu, onset=_onset.onsets(f, nu, geometry), **options)
    return f, nu, amp


def _estimates(f, nu, amp, found, scale, chirps: Chirps, geometry: Geometry, method: Method,
               couple: bool) -> Estimates:
    """Normalised (f, nu, amp) (C, K) -> Estimates in physical units; NaN where `found` is False. nu is read at the
    centre of the samples its sums ran over (Geometry.doppler_scale_at, the delay from the beat): from the echo's
    onset on where the method refines, the whole window where it reads the map."""
    nu = (nu + 0.5) % 1.0 - 0.5
    n_samp = geometry.n_samples
    first = _onset.onsets(f, nu, geometry).read if method.refine is not None else 0
    velocity = geometry.velocity_from_slow_freq(nu, sample=(first + n_samp - 1) / 2.0,
                                                delay_s=(f % 1.0) * geometry.fs_hz / geometry.slope_hz_per_s)
    return _in_units(f, velocity, amp, found, scale, chirps, geometry, method.name, couple)


def _in_units(f, velocity, amp, found, scale, chirps: Chirps, geometry: Geometry, method: str,
              couple: bool) -> Estimates:
    """Beat f [cycles/sample], velocity [m/s] and normalised amplitude (C, K) -> Estimates; NaN where `found` is
    False, and NaN velocity in cycles with fewer than two active chirps."""
    beat_hz = (f % 1.0) * geometry.fs_hz
    velocity = np.where(chirps.count[:, None] < 2, np.nan, velocity)
    range_m = geometry.range_from_beat(beat_hz, np.nan_to_num(velocity) if couple else 0.0)
    nan = np.nan
    return Estimates(range_m=np.where(found, range_m, nan), velocity_mps=np.where(found, velocity, nan),
                     beat_hz=np.where(found, beat_hz, nan),
                     amplitude=np.where(found, amp * (scale[:, None] * (1.0 if geometry.iq else 2.0)), nan),
                     n_found=found.sum(axis=1).astype(np.int64), method=method)


def refine_at(frames, rho, geometry: Geometry, f0, nu0, *, method: str = DEFAULT_METHOD, n_newton: int = 1,
              music_length: int | None = None, couple: bool = True, max_speed_mps: float = 0.0,
              lsb: float | None = None) -> Estimates:
    """Targets found elsewhere (a CFAR list, say) refined by `method` from where they were found.

    f0, nu0   float (n_cycles, K): beat [cycles/sample] and slow-time frequency [cycles/chirp] of each target
              (its cell), NaN after the last target of a cycle (targets first, padding after)
    ml, music and root_music refine every target of a cycle jointly (the others cancelled, as in `estimate`);
    fft_peak keeps the cells. Amplitudes are measured at the final frequencies.
    max_speed_mps > 0: every target is refined alone along its range walk instead (estimate/migration.py): the
    velocity alias within +-max_speed_mps whose walk integrates most power is kept, so velocities are unaliased
    and ranges refer to the cycle's first chirp, coupling removed with the unaliased velocity (method ignored).
    lsb: frames are ADC codes, as in `estimate`.
    """
    if max_speed_mps > 0:
        return _refine_walking(frames, rho, geometry, f0, nu0, max_speed_mps, couple, lsb)
    chosen = method_named(method)
    frames, rho = check_inputs(frames, rho, geometry, lsb)
    f0, nu0 = np.asarray(f0, dtype=float), np.asarray(nu0, dtype=float)
    if f0.ndim != 2 or f0.shape != nu0.shape or f0.shape[0] != frames.shape[0]:
        raise ValueError(f"refine_at: f0 {f0.shape} and nu0 {nu0.shape} must be (n_cycles, K) for "
                         f"{frames.shape[0]} cycles")
    present = np.isfinite(f0) & np.isfinite(nu0)
    counts = present.sum(axis=1)
    if not np.array_equal(present, np.arange(f0.shape[1])[None, :] < counts[:, None]):
        raise ValueError("refine_at: every cycle lists its targets first, NaN padding after")
    chirps = Chirps.of(rho)
    _, scale, valid = normalise(frames, chirps, lsb)
    f, nu, amp = np.where(present, f0, 0.0), np.where(present, nu0, 0.0), np.zeros(f0.shape)
    options = {"n_newton": n_newton, "music_length": music_length, "iq": geometry.iq}
    for k in np.unique(counts[counts > 0]):      # cycles with the same number of targets refine together
        rows = np.flatnonzero(counts == k)
        sub = Chirps.of(rho[rows])
        x, _, _ = normalise(frames[rows], sub, lsb)
        fs, nus = f[rows, :k], nu[rows, :k]
        if chosen.start_pad is not None:
            fs, nus = _grid.interpolate(x, sub, fs, nus, geometry.iq, chosen.start_pad)
        if chosen.refine is not None:
            fs, nus, amps = chosen.refine(x, sub, fs, nus, onset=_onset.onsets(fs, nus, geometry), **options)
        else:
            amps = np.stack([np.abs((demod_slow(x, sub, fs[:, j]) * spectral.phasor(nus[:, j], sub.n_chirps)
                                     * sub.rho).sum(axis=1)) / (x.shape[-1] * np.maximum(sub.count, 1))
                             for j in range(k)], axis=1)
        f[rows, :k], nu[rows, :k], amp[rows, :k] = fs, nus, amps
    return _estimates(f, nu, amp, present & valid[:, None], scale, chirps, geometry, chosen, couple)


def _refine_walking(frames, rho, geometry: Geometry, f0, nu0, max_speed_mps: float, couple: bool,
                    lsb: float | None) -> Estimates:
    """refine_at with max_speed_mps > 0: every listed target refined alone along its range walk."""
    frames, rho = check_inputs(frames, rho, geometry, lsb)
    f0, nu0 = np.asarray(f0, dtype=float), np.asarray(nu0, dtype=float)
    present = np.isfinite(f0) & np.isfinite(nu0)
    chirps = Chirps.of(rho)
    x, scale, valid = normalise(frames, chirps, lsb)
    f, v, amp = (np.full(f0.shape, np.nan) for _ in range(3))
    for j in range(f0.shape[1]):
        rows = np.flatnonzero(present[:, j] & valid)
        if rows.size:
            f[rows, j], v[rows, j], amp[rows, j] = refine_walking(
                x[rows], chirps.index[rows], chirps.mask[rows], chirps.n_chirps, f0[rows, j], nu0[rows, j], geometry,
                max_speed_mps)
    return _in_units(f, v, amp, present & valid[:, None], scale, chirps, geometry, "ml_walking", couple)
