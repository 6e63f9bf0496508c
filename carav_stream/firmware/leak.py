"""The echoes' leak into the silent slots: what it does to C(eta)'s false-alarm rate, and where it stops.

A silent slot that follows an active one can hold some of the previous chirp's echo: in band wherever that echo's
spill beat S (tau - T_c) - f_D passes the IF filter (the beat fidelity renders this too), and at waveform fidelity
also the edges the IF filter spreads, of the echo cut off by the ramp's reset and of its out-of-band spill ending at
the round trip (0.16-0.6 of one sample's echo power when the ADC samples from the reset on; 0.02-0.03 at the
round trip once it starts later). The detector's law assumes nothing of the echo there. With E the leaked energy
over one silent slot, the slot's D0 follows

    nu D0^2 / (eta_scale^2)  ~  ncx2(nu, lambda),   lambda = (nu / N_s) E / sigma_eff^2

(sigma_eff the ADC output's noise RMS), instead of chi2(nu). With L silent slots that follow an active one in a
cycle (M^2 / (2M - 1) on average for a balanced sequence of 2M chirps; the cycle's first slot counted once in two),

    P(quiet) = P_0(quiet) * (F_lambda(x) / F_0(x))^L,     x = nu eta^2 (sigma_det / sigma_eff)^2,

P_0 the leak-free closed form of `carav_stream.firmware.design`. The expected L in the exponent overstates the
rate slightly (r^L is convex in L), so a warning errs towards warning. Leaks from several targets add their
energies (worst case: in phase).

A scene is warned about when its echoes push the rate above LEAK_FACTOR times the larger of the leak-free rate and
the rate it was designed for. The warning names the boundary: the largest RCS at the target's range and the ranges
at its RCS (scanned from 0.25 m to 1.15 x the maximum range, both fidelities) within which it would exceed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import optimize, stats

from carav_stream.core.units import C_MPS
from carav_stream.firmware.design import PF_WARN, pf_per_cycle, rms_threshold, scene_law
from carav_stream.radar import physics
from carav_stream.radar.scene import Scene

__all__ = ["LEAK_FACTOR", "Leak", "silent_energy", "pf_with_leak", "scene_leaks", "leak_warnings"]

LEAK_FACTOR = 2.0          # a leak that at least doubles the false-alarm rate per cycle is worth a warning
SCAN_POINTS = 160


@dataclass(frozen=True)
class Leak:
    """One target's leak into the silent slot after its active chirp, at the fidelity where it is larger.

    fraction      leaked energy over the energy of one full slot of its echo (N_s samples)
    lam           the noncentrality it adds to one silent slot's D0 law
    pf, pf_free   C(eta)'s false-alarm rate per cycle with the leak, and without
    limit         the rate beyond which it is warned about
    rcs_limit_m2  the largest RCS at this range for which pf stays within the limit (inf: none)
    ranges_over   at this RCS, the ranges [from, to) in metres where pf exceeds the limit (gaps under a quarter of
                  their range merged: the leak ripples with where the round trip falls between two samples); None
                  when not scanned (the target does not exceed)
    """

    target: int
    range_m: float
    rcs_m2: float
    fidelity: str
    fraction: float
    lam: float
    eta: float
    pf: float
    pf_free: float
    limit: float
    rcs_limit_m2: float
    ranges_over: tuple[tuple[float, float], ...] | None

    @property
    def exceeds(self) -> bool:
        return self.pf > self.limit


def _probe(scene: Scene) -> Scene:
    """The scene cut to two chirps and no targets: the replicas below are evaluated on it."""
    return replace(scene, n_chirps=2, targets=(), attackers=())


def silent_energy(scene: Scene, tau0_s: float, alpha: float, fidelity: str) -> float:
    """Energy a unit-amplitude replica delayed by tau0_s (tau = tau0_s + alpha t) leaves in the silent slot after
    its active one, summed over the slot's samples, at the echo's worst carrier phase.

    For I/Q the energy does not depend on the phase. For I only, what the filter leaves of a cut-off tone does:
    with z the slot's samples as a complex tone (its real part at two carrier phases a quarter turn apart, tau0
    and tau0 + 1 / (4 fc)), the energy at phase theta is (sum |z|^2 + Re(e^{2 j theta} sum z^2)) / 2, at most
    (sum |z|^2 + |sum z^2|) / 2. The Doppler turns the phase from chirp to chirp, so some slot of a cycle meets it.
    The range's walk over a cycle moves the edges too: the largest rendered slot is this within a few per cent
    (tests/firmware/test_leak.py).
    """
    probe = _probe(scene)
    render = physics.beat_replica if fidelity == "beat" else physics.waveform_replica

    def tail(tau: float) -> np.ndarray | None:
        t = render(probe, tau, alpha, 1.0)[1]
        return None if t is None else t[1].astype(np.complex128)

    z = tail(tau0_s)
    if z is None:
        return 0.0
    if scene.iq:
        return float(np.sum(np.abs(z) ** 2))
    z = z - 1j * tail(tau0_s + 0.25 / scene.fc_hz)
    return float(0.5 * (np.sum(np.abs(z) ** 2) + abs(np.sum(z * z))))


def _worst_fidelity(scene: Scene, tau0_s: float, alpha: float) -> tuple[str, float]:
    """(fidelity, silent_energy) of the fidelity that leaves more in the silent slot (beat on a tie)."""
    return max(((f, silent_energy(scene, tau0_s, alpha, f)) for f in ("beat", "waveform")), key=lambda p: p[1])


def _log_ratio(lam: np.ndarray, nu: int, x: float) -> np.ndarray:
    """log(F_lambda(x) / F_0(x)) for the chi-square laws of one silent slot, resolved for tiny differences."""
    sf0 = stats.chi2.sf(x, nu)
    lam = np.asarray(lam, dtype=np.float64)
    sf = np.where(lam > 0, stats.ncx2.sf(x, nu, np.maximum(lam, 1e-300)), sf0)
    return np.log1p(-np.clip((sf - sf0) / (1.0 - sf0), 0.0, 1.0 - 1e-16))


def _n_leaking(n_chirps: int) -> float:
    m = n_chirps // 2
    return (m - 1) * m / (2 * m - 1) + 0.5      # slots 1..2M-1 after an active one, and slot 0 once in two


def pf_with_leak(law, eta: float, lam, sigma_det: float | None = None, pf0: float | None = None) -> np.ndarray:
    """C(eta)'s false-alarm rate per cycle when every silent slot after an active one holds a leak of
    noncentrality lam (vectorised over lam); pf0: the leak-free rate, if known."""
    pf0 = float(pf_per_cycle(law, eta, sigma_det)) if pf0 is None else pf0
    x = law.dof * (eta * (sigma_det or law.sigma_n) / law.sigma_eff) ** 2
    log_quiet = math.log1p(-pf0) + _n_leaking(law.n_chirps) * _log_ratio(lam, law.dof, x)
    return -np.expm1(log_quiet)


def _lam(scene: Scene, law, energy_per_unit: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    return (law.dof / scene.n_samples) * energy_per_unit * amplitude ** 2 / law.sigma_eff ** 2


def _intervals(r: np.ndarray, over: np.ndarray) -> tuple[tuple[float, float], ...]:
    out: list[list[float]] = []
    for i in np.flatnonzero(over):
        lo, hi = float(r[i]), float(r[min(i + 1, r.size - 1)])
        if out and lo - out[-1][1] < 0.25 * lo:
            out[-1][1] = hi
        else:
            out.append([lo, hi])
    return tuple((a, b) for a, b in out)


def _ranges_over(scene: Scene, law, target, alpha: float, lam_limit: float) -> tuple[tuple[float, float], ...]:
    """The ranges where this target, at its RCS and range rate, would exceed the limit (both fidelities)."""
    r_scan = np.geomspace(0.25, 1.15 * scene.max_range_m, SCAN_POINTS)
    per_unit = np.array([_worst_fidelity(scene, 2.0 * r / C_MPS, alpha)[1] for r in r_scan])
    amps = np.array([physics.echo_amplitude(scene, replace(target, range_m=float(r))) for r in r_scan])
    return _intervals(r_scan, _lam(scene, law, per_unit, amps) > lam_limit)


def scene_leaks(scene: Scene, eta: float | None = None, *, pf_design: float = PF_WARN,
                sigma_det: float | None = None) -> list[Leak]:
    """Every target's leak at the scene's eta (default: the eta designed for pf_design); the ranges where it
    exceeds are scanned for the targets that exceed."""
    if not scene.targets or scene.sigma_n <= 0:
        return []
    law = scene_law(scene)
    eta = rms_threshold(law, pf_design, sigma_det) if eta is None else float(eta)
    pf_free = float(pf_per_cycle(law, eta, sigma_det))
    limit = LEAK_FACTOR * max(pf_free, pf_design)
    # the noncentrality at which the rate reaches the limit (pf rises with lambda)
    def excess(log_lam: float) -> float:
        return float(pf_with_leak(law, eta, math.exp(log_lam), sigma_det, pf_free)) - limit
    lam_limit = math.inf if limit >= 1 or excess(math.log(1e9)) < 0 else math.exp(
        optimize.brentq(excess, math.log(1e-12), math.log(1e9), xtol=1e-6))
    leaks = []
    for i, target in enumerate(scene.targets):
        tau0, alpha = physics.target_delay(scene, target)
        amp = physics.echo_amplitude(scene, target)
        fidelity, silent = _worst_fidelity(scene, tau0, alpha)
        lam = float(_lam(scene, law, np.float64(silent), np.float64(amp)))
        fraction = silent / (scene.n_samples * (1.0 if scene.iq else 0.5))    # of a full slot of unit-amplitude echo
        rcs_limit = math.inf if lam_limit == math.inf else (target.rcs_m2 * lam_limit / lam if lam > 0 else math.inf)
        pf = float(pf_with_leak(law, eta, lam, sigma_det, pf_free))
        spans = _ranges_over(scene, law, target, alpha, lam_limit) if pf > limit else None
        leaks.append(Leak(i, target.range_m, target.rcs_m2, fidelity, fraction, lam, eta, pf, pf_free, limit,
                          rcs_limit, spans))
    return leaks


def _ranges(spans) -> str:
    return ", ".join(f"{a:.3g}-{b:.3g} m" for a, b in spans) or "no range scanned"


def leak_warnings(scene: Scene, eta: float | None = None, *, pf_design: float = PF_WARN,
                  sigma_det: float | None = None, who: str = "C(eta)") -> list[str]:
    """One line per target whose echo leaks enough into the silent slots to raise the false-alarm rate."""
    out = []
    for k in scene_leaks(scene, eta, pf_design=pf_design, sigma_det=sigma_det):
        if not k.exceeds:
            continue
        out.append(
            f"targets[{k.target}] ({k.range_m:g} m, {k.rcs_m2:g} m^2): {k.fraction:.2g} of a slot of its echo leaks "
            f"into each silent slot after an active one ({k.fidelity} fidelity, {10 * math.log10(k.lam):+.1f} dB "
            f"over the slot's noise at its worst phase), so {who} at eta = {k.eta:.4g} alarms on up to {k.pf:.2g} of "
            f"attack-free cycles "
            f"({k.pf_free:.2g} without it; warned above {k.limit:.2g}). Within that: below {k.rcs_limit_m2:.3g} m^2 at "
            f"{k.range_m:g} m; at {k.rcs_m2:g} m^2 it exceeds at {_ranges(k.ranges_over)} (a later ADC start, "
            "t_adc_start_s, removes what the ramp's reset leaves)")
    return out
