"""The paper's own signal model, for Monte Carlo of the detector without the full radar chain.

    R_k[m] = n_k[m] + rho(k) x_k[m] + a_k[m],     k = 0..N_r-1,  m = 0..N_s-1       (Section IV)

n_k i.i.d. Gaussian with RMS sigma_n (I-only: N(0, sigma_n^2) per sample; I/Q: sigma_n^2 / 2 per component), x_k a
deterministic beat sinusoid (one target, phase advancing from chirp to chirp with the Doppler), and a_k the attack:

    none     a_k = 0
    random   a_k i.i.d. Gaussian with RMS sigma_a = RARMS * sigma_n on every chirp (Section V.D)
    smart    one Gaussian sequence a of RMS sigma_a per cycle, repeated on every chirp (Section V.E)

Two exact ways to draw a cycle:

- `simulate_frames`: every sample (the "full simulation").
- `sample_rms`: the per-chirp RMS directly from its exact law (the detector sees nothing else). With nu real degrees
  of freedom (nu = N_s for I-only, 2 N_s for I/Q) and s^2 = sigma_n^2 N_s / nu the noise variance per real
  dimension, the energy of chirp k is E_k = ||R_k||^2 / s^2 ~ noncentral chi2(nu, ||mean_k||^2 / s^2) given the
  Gaussian parts, and ||R_k||_r = sigma_n sqrt(E_k / nu). For `random` the attack just adds variance
  (s^2 -> s^2 (1 + RARMS^2)). For `smart` the shared sequence a couples the chirps: a is split into its projection g
  on the span of the echoes (d Gaussians) and the orthogonal rest (s_a^2 chi2(nu - d)); given those, the chirps are
  independent with noncentrality (||c_k + g||^2 + w) / s^2, where c_k are the echo coordinates. Both are exact.

Q itself, for the Monte Carlo, from the same laws without the per-chirp RMS array: `sample_q_fast` (no attack or
`random`: the largest silent energy by inverse transform) and `sample_q_smart` (`smart`: every chirp's energy from
vectorised exact generators, the detector's reductions fused in).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from carav_stream.core.allocator import scratch
from carav_stream.montecarlo.samplers import balanced_mask, chi2_and_normal
from carav_stream.radar.scene_loader import load_scene

__all__ = ["PaperScene", "paper_scene", "simulate_frames", "sample_rms", "sample_q_fast", "sample_q_smart",
           "exchangeable", "check_attack", "gaussian", "ATTACKS"]

ATTACKS = ("none", "random", "smart")

@dataclass(frozen=True)
class PaperScene:
    """A scene of the paper's model.

    name       label
    n_chirps   N_r (even)
    n_samples  N_s per chirp
    iq         complex I/Q samples (True) or in-phase only (False)
    sigma_n    noise RMS per sample (volts, arbitrary unit)
    echo       (n_chirps, n_samples) float64 | complex128: x_k, received when rho(k) = 1
    """

    name: str
    n_chirps: int
    n_samples: int
    iq: bool
    sigma_n: float
    echo: np.ndarray = field(repr=False)

    @property
    def dof(self) -> int:
        """Real degrees of freedom per chirp, nu."""
        return self.n_samples * (2 if self.iq else 1)

    @property
    def echo_real(self) -> np.ndarray:
        """Echo as real vectors, (n_chirps, nu)."""
        if self.iq:
            return np.concatenate([self.echo.real, self.echo.imag], axis=-1)
        return self.echo

    @property
    def echo_snr(self) -> float:
        """Mean echo power over noise power, ||x||_r^2 / sigma_n^2."""
        return float(np.mean(np.abs(self.echo) ** 2) / self.sigma_n ** 2)

    @cached_property
    def echo_coords(self) -> np.ndarray:
        """Coordinates c_k of the echoes in an orthonormal basis of their span, (n_chirps, d), computed once per
        scene (not once per Monte Carlo batch: a BLAS call wakes threads that then compete with the batch).

        From the Gram matrix X X^T = U S^2 U^T (n_chirps x n_chirps, cheap) instead of an SVD of X: c = U S.
        """
        x = self.echo_real
        evals, evecs = np.linalg.eigh(x @ x.T)
        keep = evals > max(float(evals.max()), 0.0) * 1e-12
        return evecs[:, keep] * np.sqrt(evals[keep])


def paper_scene(preset: str = "table1", *, n_chirps: int | None = None, n_samples: int | None = None,
                iq: bool = False, sigma_n: float = 1.0, snr_db: float = 0.0) -> PaperScene:
    """A paper-model scene with the chirp structure and first target of a radar preset (`table1` = Table I,
    `awr1642` = Table II; carav_stream/radar/presets), at the echo SNR `snr_db` per sample (the paper: 0 dB)."""

    radar = load_scene(preset)
    n_r = radar.n_chirps if n_chirps is None else int(n_chirps)
    n_s = radar.n_samples if n_samples is None else int(n_samples)
    if n_r < 2 or n_r % 2:
        raise ValueError(f"n_chirps: must be even and >= 2, got {n_r}")
    if n_s < 2:
        raise ValueError(f"n_samples: must be >= 2, got {n_s}")
    if not sigma_n > 0:
        raise ValueError(f"sigma_n: must be > 0, got {sigma_n}")
    target = radar.targets[0]
    f_beat_hz = radar.beat_hz(target)
    doppler_hz = 2 * radar.range_rate_mps(target) / radar.wavelength_m
    m = np.arange(n_s)
    phase = (2 * np.pi * f_beat_hz / radar.fs_hz * m[None, :]
             + 2 * np.pi * doppler_hz * radar.t_chirp_s * np.arange(n_r)[:, None] + 0.3)
    amp = sigma_n * 10 ** (snr_db / 20)
    if iq:
        echo = np.exp(1j * phase)
    else:
        echo = np.cos(phase)
    # every chirp gets exactly the echo RMS amp (a real sinusoid's RMS depends slightly on its phase when the
    # window is not a whole number of periods), so the chirps are exchangeable as the paper's model assumes
    echo = echo * (amp / np.sqrt(np.mean(np.abs(echo) ** 2, axis=-1, keepdims=True)))
    return PaperScene(preset, n_r, n_s, bool(iq), float(sigma_n), echo)


def check_attack(attack: str, rarms: float) -> None:
    """ValueError naming the attack or RARMS unless the paper model has that attack and RARMS is finite and >= 0."""
    if attack not in ATTACKS:
        raise ValueError(f"attack: unknown {attack!r} for the paper model, expected one of {ATTACKS}")
    if not (np.isfinite(rarms) and rarms >= 0):
        raise ValueError(f"rarms: must be finite and >= 0, got {rarms!r}")


def gaussian(rng: np.random.Generator, shape, rms: float, iq: bool, dtype) -> np.ndarray:
    """White Gaussian samples of RMS rms per sample, shape `shape`: real of dtype, or complex of dtype with rms^2 / 2
    per component (drawn as interleaved real pairs)."""
    if iq:
        z = rng.standard_normal((*shape, 2), dtype=np.float32 if dtype == np.complex64 else np.float64)
        z *= rms / np.sqrt(2.0)
        return z.view(dtype)[..., 0]
    z = rng.standard_normal(shape, dtype=dtype)
    z *= rms
    return z


def simulate_frames(scene: PaperScene, rho: np.ndarray, rng: np.random.Generator, attack: str = "none",
                    rarms: float = 0.0, *, dtype=None) -> np.ndarray:
    """Full-sample cycles of the paper's model.

    rho      bool (n_cycles, n_chirps), balanced
    returns  (n_cycles, n_chirps, n_samples) float32 (I-only) or complex64 (I/Q) unless dtype says otherwise
    """
    check_attack(attack, rarms)
    rho = np.asarray(rho, dtype=bool)
    n_cycles = rho.shape[0]
    dtype = np.dtype(dtype or (np.complex64 if scene.iq else np.float32))
    shape = (n_cycles, scene.n_chirps, scene.n_samples)
    frames = gaussian(rng, shape, scene.sigma_n, scene.iq, dtype)
    np.add(frames, scene.echo.astype(dtype)[None], out=frames, where=rho[..., None])
    sigma_a = rarms * scene.sigma_n
    if attack == "random" and sigma_a > 0:
        frames += gaussian(rng, shape, sigma_a, scene.iq, dtype)
    elif attack == "smart" and sigma_a > 0:
        frames += gaussian(rng, (n_cycles, 1, scene.n_samples), sigma_a, scene.iq, dtype)
    return frames


def _smart_lam_active(coords: np.ndarray, g: np.ndarray, w: np.ndarray, out: np.ndarray) -> np.ndarray:
    """||c_k + g||^2 + w for every cycle and chirp into out, float64 (n_cycles, n_chirps).

    d <= 2 (one target: a sinusoid spans at most two dimensions) is built column by column in place, without the
    (n_cycles, n_chirps, d) temporary; the sum of two squares is the same number whatever the order, so this equals
    np.sum over the last axis bit for bit. Larger d keeps np.sum (its order of addition is numpy's)."""
    d = coords.shape[1]
    if d not in (1, 2):
        out[...] = np.sum((coords[None] + g[:, None, :]) ** 2, axis=-1) + w[:, None]
        return out
    np.add(coords[:, 0], g[:, 0:1], out=out)
    np.square(out, out=out)
    if d == 2:
        t = np.add(coords[:, 1], g[:, 1:2], out=scratch("t64", out.size, np.float64).reshape(out.shape))
        np.square(t, out=t)
        out += t
    out += w[:, None]
    return out


RMS_CHUNK_CYCLES = 2048       # cycles per pass of sample_rms (reused float64 buffers, 1 MB at 64 chirps)


def sample_rms(scene: PaperScene, rho: np.ndarray, rng: np.random.Generator, attack: str = "none",
               rarms: float = 0.0) -> np.ndarray:
    """Per-chirp RMS drawn from its exact law (sufficient statistic), float64 (n_cycles, n_chirps).

    The generator's stream, in order: for `smart` only, g (n_cycles, d) standard normals and w (n_cycles,)
    gammas; then (n_cycles, n_chirps) float32 gammas for chi2(nu - 1); then (n_cycles, n_chirps) float64 normals.
    Both (n_cycles, n_chirps) draws are taken RMS_CHUNK_CYCLES rows at a time into this thread's reused buffers
    (a generator fills an array element after element, so the numbers are those of one call), the gammas straight
    into the returned array; every other step works on the chunk in place, which costs less than whole-array
    temporaries (the draws themselves are most of the time).
    """
    check_attack(attack, rarms)
    rho = np.asarray(rho, dtype=bool)
    n_cycles, n_r = rho.shape
    nu = scene.dof
    s2 = scene.sigma_n ** 2 * scene.n_samples / nu            # noise variance per real dimension
    r2 = rarms ** 2
    smart = attack == "smart" and rarms > 0
    if smart:
        coords = scene.echo_coords / np.sqrt(s2)               # (n_chirps, d) in noise units
        d = coords.shape[1]
        g = rng.standard_normal((n_cycles, d)) * np.sqrt(r2)
        w = r2 * 2.0 * rng.standard_gamma((nu - d) / 2.0, size=n_cycles)
        lam_silent = np.sum(g ** 2, axis=-1) + w                # (n_cycles,)
        scale = 1.0
    else:
        scale = 1.0 + (r2 if attack == "random" else 0.0)
        echo_e = np.sum(scene.echo_real ** 2, axis=-1) / s2     # ||x_k||^2 / s^2, (n_chirps,)
        mu_active = np.sqrt(echo_e / scale)
    # noncentral chi2(nu, lam) = chi2(nu - 1) + (Z + sqrt(lam))^2, the same construction numpy uses
    energy = np.empty((n_cycles, n_r))
    step = RMS_CHUNK_CYCLES
    for a in range(0, n_cycles, step):
        m = min(step, n_cycles - a)
        gam = scratch("gamma32", m * n_r, np.float32).reshape(m, n_r)
        rng.standard_gamma((nu - 1) / 2.0, dtype=np.float32, out=gam)
        np.multiply(gam, 2.0, out=energy[a: a + m])
    for a in range(0, n_cycles, step):
        m = min(step, n_cycles - a)
        mu = scratch("mu64", m * n_r, np.float64).reshape(m, n_r)
        if smart:
            # active lam, silent lam: lam_a * rho + lam_s * (1 - rho) is each of them exactly (x + 0 = x), and
            # cheaper than a masked copy
            _smart_lam_active(coords, g[a: a + m], w[a: a + m], out=mu)
            mu *= rho[a: a + m]
            t = np.multiply(~rho[a: a + m], lam_silent[a: a + m, None],
                            out=scratch("t64", m * n_r, np.float64).reshape(m, n_r))
            mu += t
            np.sqrt(mu, out=mu)
        else:
            np.multiply(rho[a: a + m], mu_active, out=mu)
        z = rng.standard_normal(out=scratch("z64", m * n_r, np.float64).reshape(m, n_r))
        z += mu
        np.square(z, out=z)
        e = energy[a: a + m]
        e += z
        e *= scale / nu
        np.sqrt(e, out=e)
        if scene.sigma_n != 1.0:
            e *= scene.sigma_n
    return energy


def _max_chi2_table(nu: int, m: int, n_nodes: int = 16385, z_max: float = 9.0) -> tuple[np.ndarray, np.ndarray]:
    """Quantile function of max of m i.i.d. chi2(nu) on the standard-normal scale: E_max = G(z), z ~ N(0, 1).

    G(z) = F^-1(Phi(z)^(1/m)); tails computed through survival functions so the table is accurate to ~1e-10
    relative (linear interpolation on 16385 nodes of a nearly linear function).
    """
    from scipy import special, stats

    key = (nu, m, n_nodes, z_max)
    if key not in _TABLES:
        z = np.linspace(-z_max, z_max, n_nodes)
        log_u = special.log_ndtr(z) / m                     # log of the per-chirp cdf
        cdf = np.exp(log_u)
        sf = -np.expm1(log_u)
        vals = np.where(sf < 0.5, stats.chi2.isf(sf, nu), stats.chi2.ppf(cdf, nu))
        _TABLES[key] = (z, vals)
    return _TABLES[key]


_TABLES: dict = {}


def exchangeable(scene: PaperScene, attack: str) -> bool:
    """True when every chirp's law is the same up to activation (no attack or `random`, equal echo power per chirp):
    the position of the active chirps then does not change the law of Q, and the fast path applies."""
    power = np.sum(np.abs(scene.echo) ** 2, axis=-1)
    return attack in ("none", "random") and float(np.ptp(power)) <= 1e-9 * float(power.max() or 1.0)


def sample_q_fast(scene: PaperScene, n_cycles: int, rng: np.random.Generator, attack: str = "none",
                  rarms: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Q of n_cycles cycles for an exchangeable scene (see `exchangeable`), drawn from sufficient statistics.

    D0 only needs the largest silent energy: it is drawn by inverse transform, E_max = G(z) (`_max_chi2_table`),
    one normal per cycle instead of N_r/2 chi-square draws. The N_r/2 active energies are drawn as
    chi2(nu - 1) + (Z + sqrt(lam))^2 in float32 (rounding 6e-8 relative).
    returns q float64 (n_cycles,), by_d1 bool (n_cycles,).
    """
    check_attack(attack, rarms)
    if not exchangeable(scene, attack):
        raise ValueError(f"sample_q_fast: scene {scene.name!r} with attack {attack!r} is not exchangeable")
    nu, m = scene.dof, scene.n_chirps // 2
    t = 1.0 + (rarms ** 2 if attack == "random" else 0.0)
    s2 = scene.sigma_n ** 2 * scene.n_samples / nu
    lam = float(np.sum(scene.echo_real[0] ** 2)) / s2 / t
    z_nodes, e_nodes = _max_chi2_table(nu, m)
    z = rng.standard_normal(n_cycles)
    e_max = np.interp(z, z_nodes, e_nodes)
    tail = np.abs(z) > z_nodes[-1]
    if np.any(tail):                                   # probability ~2e-19 per cycle: compute exactly
        from scipy import special, stats
        log_u = special.log_ndtr(z[tail]) / m
        e_max[tail] = np.where(z[tail] > 0, stats.chi2.isf(-np.expm1(log_u), nu), stats.chi2.ppf(np.exp(log_u), nu))
    d0 = np.sqrt(e_max * (t / nu))
    # float32 throughout (relative rounding 6e-8 on the energies, far below any eta grid step); in place for speed
    a = rng.standard_gamma((nu - 1) / 2.0, size=(n_cycles, m), dtype=np.float32)
    a *= np.float32(2.0)
    z = rng.standard_normal((n_cycles, m), dtype=np.float32)
    z += np.float32(np.sqrt(lam))
    np.square(z, out=z)
    a += z
    np.sqrt(a, out=a)
    a *= np.float32(np.sqrt(t / nu))                    # active RMS in sigma_n units
    rbar = a.mean(axis=1, dtype=np.float64)
    d1 = np.maximum(a.max(axis=1) - rbar, rbar - a.min(axis=1)) / (rbar + 1.0)
    return np.maximum(d0, d1), d1 > d0


SMART_CHUNK_CYCLES = 2048     # cycles per pass of sample_q_smart (flat cost from 1024 to 8192; 0.5 MB buffers)


def sample_q_smart(scene: PaperScene, n_cycles: int, rng: np.random.Generator,
                   rarms: float) -> tuple[np.ndarray, np.ndarray]:
    """Q of n_cycles cycles under the `smart` attack, drawn from the sufficient statistics of `sample_rms` (same
    law: g, w, then every chirp's chi2(nu - 1) + (Z + sqrt(lam_k))^2) and reduced to Q without the per-chirp RMS:

        D0 = max over silent k of r_k,   D1 = max over active k of |r_k - rbar| / (rbar + 1),   r_k = sqrt(E_k / nu)

    in units of sigma_n (the detector's sigma_n is the scene's). The activation, chi2 and normal draws come from
    `samplers.balanced_mask` and `samplers.chi2_and_normal`; SMART_CHUNK_CYCLES cycles at a time, chirp-major (a
    reduction over the chirps is an element-wise pass), in this thread's reused buffers. Energies and RMS in
    float32 (rounding 6e-8 relative), rbar accumulated in float64, as `sample_q_fast`: cheaper than
    balanced_rows, sample_rms and detect_from_rms in turn. Measured: docs/bench/detector.md (the sufficient-statistic
    path under the smart attack).
    returns q float64 (n_cycles,), by_d1 bool (n_cycles,) (the largest ratio came from an active chirp).
    """
    check_attack("smart", rarms)
    if rarms > 1e15:
        raise ValueError(f"rarms: {rarms!r} is beyond the float32 energies of sample_q_smart (at most 1e15); "
                         "use sample_rms")
    nu, n_r = scene.dof, scene.n_chirps
    s2 = scene.sigma_n ** 2 * scene.n_samples / nu
    coords = scene.echo_coords / np.sqrt(s2)                    # (n_chirps, d) in noise units
    d = coords.shape[1]
    c_aug = np.hstack([2.0 * coords, np.sum(coords ** 2, axis=1, keepdims=True)]).astype(np.float32)
    q = np.empty(n_cycles)
    by_d1 = np.empty(n_cycles, dtype=bool)
    for a in range(0, n_cycles, SMART_CHUNK_CYCLES):
        m = min(SMART_CHUNK_CYCLES, n_cycles - a)
        act, mu, r, z = (scratch(name, n_r * m, np.float32).reshape(n_r, m) for name in ("act", "mu", "r", "z"))
        balanced_mask(rng, act)
        g = rng.standard_normal((m, d)) * rarms
        w = rarms ** 2 * 2.0 * rng.standard_gamma((nu - d) / 2.0, size=m)
        lam0 = (np.sum(g * g, axis=1) + w).astype(np.float32)    # silent noncentrality ||g||^2 + w
        # ||c_k||^2 + 2 c_k.g; einsum, not matmul: a BLAS call here wakes threads that compete with this one
        np.einsum("kd,dm->km", c_aug, np.vstack([g.T, np.ones((1, m))]).astype(np.float32), out=mu)
        mu *= act
        mu += lam0                                               # active: ||c_k + g||^2 + w
        np.sqrt(mu, out=mu)
        chi2_and_normal(rng, nu - 1, r, z)
        z += mu
        np.square(z, out=z)
        r += z
        r *= np.float32(1.0 / nu)
        np.sqrt(r, out=r)                                        # r_k / sigma_n
        ra = np.multiply(r, act, out=mu)                         # active r, 0 on silent chirps
        r_max = ra.max(axis=0)
        rbar = np.add.reduce(ra, axis=0, dtype=np.float64) / (n_r // 2)
        r -= ra                                                  # silent r, 0 on active chirps
        d0 = r.max(axis=0)
        with np.errstate(over="ignore"):
            r *= np.float32(1e30)                                # 0 on active chirps, >= 1e29 (or inf) on silent
        r += ra                                                  # active r, huge on silent chirps
        d1 = np.maximum(r_max - rbar, rbar - r.min(axis=0)) / (rbar + 1.0)
        np.maximum(d0, d1, out=q[a: a + m])
        np.greater(d1, d0, out=by_d1[a: a + m])
    return q, by_d1
