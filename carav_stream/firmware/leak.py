"""The echoes' leak into the silent slots: what it does to C(eta)'s false-alarm rate, and where it stops.

A silent slot that follows an active one can hold some of the previous chirp's echo: in band wherever that echo's
spill beat S (tau - T_c) - f_D passes the IF filter (the beat fidelity renders this too), and at waveform fidelity
also the edges the IF filter spreads, of the echo cut off by the ramp's reset and of its out-of-band spill ending at
the round trip (up to 0.16-0.6 of one sample's echo power when the ADC samples from the reset on; 0.02-0.03 at the
round trip once it starts later). The detector's law assumes nothing of the echo there.

The rate. Each target's tail in every slot of the cycle, as the chain renders it at each fidelity, gives C(eta)'s
false-alarm rate per cycle exactly, averaged over the balanced random activation (the derivation:
`carav_stream.firmware.silent_slots`); a target is judged at the fidelity where its rate is larger. Each target is
judged alone: the tails of several targets add in the slots as their phases fall.

The warning. A target is warned about when its leak pushes the rate above LEAK_FACTOR times the larger of the
leak-free rate and the rate it was designed for. The warning names the boundary: the largest RCS at the target's
range (every lambda_k grows in proportion to the RCS: a root in one variable), and the ranges at its RCS within
which the rate exceeds the limit. The rate ripples as the range moves by fractions of a wavelength (the carrier
phase at which the reset cuts the echo), so the ranges are those where it exceeds at the worst of PHASES carrier
phases: located on SCAN_POINTS ranges from 0.25 m to 1.15 x the maximum range (both fidelities, the scene's ADC as
set), each end refined to a millimetre. There each slot's tail is the first slot's turned by the phase the echo
gains from chirp to chirp, at the frequency the emission has where the tail leaves it: that leaves out how the
range's walk over the cycle moves the tail's beat (slot energies within 1 % of the rendered ones for the table1 car,
5 % for awr1642's 300 km/h closing speed), and costs two renders of one slot per range instead of a cycle's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import optimize

from carav_stream.core.units import C_MPS
from carav_stream.firmware.design import PF_WARN, QUANTISED_BELOW, pf_per_cycle, rms_threshold, scene_law
from carav_stream.firmware.silent_slots import noncentrality, pf_with_leak, slot_deficits, slot_energies
from carav_stream.radar import physics
from carav_stream.radar.scene import Scene

__all__ = ["LEAK_FACTOR", "Leak", "scene_rate", "scene_leaks", "leak_warnings"]

LEAK_FACTOR = 2.0          # a leak that at least doubles the false-alarm rate per cycle is worth a warning
SCAN_POINTS = 160
PHASES = 8                 # carrier phases of the boundary's scan, over half a turn
FIDELITIES = ("beat", "waveform")


@dataclass(frozen=True)
class Leak:
    """One target's leak into the silent slots after its active chirps, at the fidelity where the rate is larger.

    fraction      the largest share, over the cycle's slots, of one full slot of its echo (N_s samples) that leaks
    lam           that slot's noncentrality (the largest lambda_k)
    pf, pf_free   C(eta)'s false-alarm rate per cycle with the leak (exact, over the balanced random activation),
                  and without
    limit         the rate beyond which it is warned about
    rcs_limit_m2  the largest RCS at this range for which pf stays within the limit (inf: any; nan: not sought)
    ranges_over   at this RCS, the ranges [from, to) in metres where pf exceeds the limit (gaps under a quarter of
                  their range merged: the leak ripples with where the round trip falls between two samples); None
                  when not scanned (the target does not exceed)
    judged        False where the ADC's step is coarse against the noise (design.QUANTISED_BELOW): the rate, the RCS
                  limit and the ranges are not stated there (nan, nan, None), the tails' laws taking quantisation
                  as uniform noise; peak_steps then bounds the tail's largest sample, in ADC steps
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
    judged: bool = True
    peak_steps: float = 0.0

    @property
    def exceeds(self) -> bool:
        return self.pf > self.limit


@dataclass(frozen=True)
class _Judge:
    """What every rate of one scene and eta shares."""

    scene: Scene
    law: object
    eta: float
    pf_free: float
    limit: float
    sigma_det: float | None

    def rate(self, lam: np.ndarray) -> np.ndarray:
        return pf_with_leak(self.law, self.eta, lam, self.pf_free, self.sigma_det)

    def lams(self, tau0_s: float, alpha: float, amplitude: float) -> dict[str, np.ndarray]:
        """Each fidelity's lambda_k over the cycle, from the rendered tails."""
        return {f: noncentrality(self.law, self.scene, slot_energies(self.scene, tau0_s, alpha, f, amplitude))
                for f in FIDELITIES}

    def worst(self, lams: dict[str, np.ndarray], scale: float = 1.0) -> tuple[str, float]:
        """(fidelity, rate) of the fidelity with the larger rate (beat on a tie)."""
        return max(((f, float(self.rate(scale * lam))) for f, lam in lams.items()), key=lambda p: p[1])


def _turned(scene: Scene, tau0_s: float, alpha: float, fidelity: str) -> np.ndarray:
    """Tail energies per unit amplitude, (PHASES, n_chirps), at PHASES carrier phases of the first slot's tail spread
    over half a turn, each turned from chirp to chirp as the echo's phase turns. For I only, the energy at phase
    theta of an analytic tail z is (sum |z|^2 + Re(e^{2 j theta} sum z^2)) / 2 (z from two renders a quarter
    carrier period apart); for I/Q it does not depend on the phase."""
    probe = replace(scene, n_chirps=2, targets=(), attackers=())
    render = physics.beat_replica if fidelity == "beat" else physics.waveform_replica
    out = np.zeros((PHASES, scene.n_chirps))
    t = render(probe, tau0_s, alpha, 1.0)[1]
    if t is None:
        return out
    z = t[1].astype(np.complex128)
    if scene.iq:
        out[:, 1:] = np.sum(np.abs(z) ** 2)
        return out
    z = z - 1j * render(probe, tau0_s + 0.25 / scene.fc_hz, alpha, 1.0)[1][1]
    f_emit = scene.fc_hz + scene.slope_hz_per_s * min(scene.t_chirp_s - tau0_s, scene.t_sweep_s)
    theta = np.pi * np.arange(PHASES)[:, None] / PHASES + 2 * np.pi * f_emit * alpha * scene.t_chirp_s \
        * np.arange(scene.n_chirps - 1)[None, :]
    out[:, 1:] = 0.5 * (np.sum(np.abs(z) ** 2) + np.real(np.exp(2j * theta) * np.sum(z * z)))
    return out


def _envelope(judge: _Judge, target, alpha: float, r: np.ndarray) -> np.ndarray:
    """The rate at the worst carrier phase (PHASES of them) and fidelity, per range r, from the turned tails; below
    the limit, a bound on it may stand in."""
    scene = judge.scene
    amps = np.array([physics.echo_amplitude(scene, replace(target, range_m=float(x))) for x in r])
    lam = np.stack([np.stack([_turned(scene, 2.0 * float(x) / C_MPS, alpha, f) for x in r]) for f in FIDELITIES])
    lam = noncentrality(judge.law, scene, lam * amps[None, :, None, None] ** 2)      # (fidelity, range, phase, k)
    return _bounded_rate(judge, lam).max(axis=0)


def _bounded_rate(judge: _Judge, lam: np.ndarray) -> np.ndarray:
    """judge.rate(lam).max(axis=-2), lam (..., phase, k), computed exactly only where bounds leave it on either side
    of the limit: no cycle has more than M silent slots after an active one (each at most the largest deficit:
    above), and all but one activation in C(2M, M) have one at least (at least the smallest deficit: below)."""
    m, pf0 = judge.law.n_chirps // 2, min(judge.pf_free, 1.0 - 1e-16)
    q_max = slot_deficits(judge.law, judge.eta, lam.max(axis=(-2, -1)), judge.sigma_det)
    q_min = slot_deficits(judge.law, judge.eta, lam[..., 1:].min(axis=-1), judge.sigma_det).max(axis=-1)
    with np.errstate(divide="ignore"):
        above = -np.expm1(math.log1p(-pf0) + m * np.log1p(-q_max))
    below = pf0 + (1.0 - pf0) * q_min * -math.expm1(-math.lgamma(2 * m + 1) + 2 * math.lgamma(m + 1))
    out = np.where(below > judge.limit, below, above)
    open_ = (above > judge.limit) & (below <= judge.limit)
    if open_.any():
        out[open_] = judge.rate(lam[open_]).max(axis=-1)
    return out


def _spans(r: np.ndarray, over: np.ndarray) -> list[list[int]]:
    """Index spans [first, last] of the grid points over the limit, gaps under a quarter of their range merged."""
    out: list[list[int]] = []
    for i in np.flatnonzero(over).tolist():
        if out and r[i] - r[out[-1][1]] < 0.25 * r[i]:
            out[-1][1] = i
        else:
            out.append([i, i])
    return out


def _ranges_over(judge: _Judge, target, alpha: float) -> tuple[tuple[float, float], ...]:
    """The ranges where this target, at its RCS and range rate and the worst carrier phase, would exceed the limit
    (both fidelities), each end refined to a millimetre between its grid points."""
    r = np.geomspace(0.25, 1.15 * judge.scene.max_range_m, SCAN_POINTS)

    def crossing(i: int) -> float:
        return float(optimize.brentq(lambda x: float(_envelope(judge, target, alpha, np.array([x]))[0]) - judge.limit,
                                     float(r[i]), float(r[i + 1]), xtol=1e-3))

    spans = _spans(r, _envelope(judge, target, alpha, r) > judge.limit)
    return tuple((float(r[0]) if a == 0 else crossing(a - 1), float(r[-1]) if b == r.size - 1 else crossing(b))
                 for a, b in spans)


def _rcs_limit(judge: _Judge, target, lams: dict[str, np.ndarray]) -> float:
    """The largest RCS at the target's range whose rate stays within the limit."""
    def excess(log_scale: float) -> float:
        return judge.worst(lams, math.exp(log_scale))[1] - judge.limit

    if judge.limit >= 1 or not any(lam.any() for lam in lams.values()) or excess(math.log(1e12)) < 0:
        return math.inf
    if excess(math.log(1e-12)) > 0:
        return 0.0
    return target.rcs_m2 * math.exp(optimize.brentq(excess, math.log(1e-12), math.log(1e12), xtol=1e-6))


def scene_rate(scene: Scene, eta: float, fidelity: str, sigma_det: float | None = None) -> float:
    """C(eta)'s false-alarm rate per cycle on the scene's attack-free cycles at `fidelity`, exactly (the law of
    firmware/design.py): every target's tail in every slot, summed as the channel adds them (`physics.echo_templates`;
    fluctuating targets at their mean RCS), averaged over the balanced random activation."""
    law = scene_law(scene)
    pf0 = float(pf_per_cycle(law, eta, sigma_det))
    tails = physics.echo_templates(scene, fidelity).tail_sum
    if tails is None:
        return pf0
    t = tails.astype(np.complex128)
    energy = np.sum(t.real ** 2 + t.imag ** 2, axis=-1)
    energy[0] = 0.0                                         # the chirp before the cycle is silent
    return float(pf_with_leak(law, eta, noncentrality(law, scene, energy), pf0, sigma_det))


def scene_leaks(scene: Scene, eta: float | None = None, *, pf_design: float = PF_WARN,
                sigma_det: float | None = None, every_limit: bool = True) -> list[Leak]:
    """Every target's leak at the scene's eta (default: the eta designed for pf_design); the ranges where it
    exceeds are scanned for the targets that exceed. `every_limit` False: the RCS limit is sought only for the
    targets that exceed (the others' rcs_limit_m2 nan), which is all a warning states (a root search per target)."""
    if not scene.targets or scene.sigma_n <= 0:
        return []
    law = scene_law(scene)
    eta = rms_threshold(law, pf_design, sigma_det) if eta is None else float(eta)
    pf_free = float(pf_per_cycle(law, eta, sigma_det))
    judge = _Judge(scene, law, eta, pf_free, LEAK_FACTOR * max(pf_free, pf_design), sigma_det)
    full_slot = scene.n_samples * (1.0 if scene.iq else 0.5)      # energy of a full slot of unit-amplitude echo
    coarse = law.steps() < QUANTISED_BELOW
    leaks = []
    for i, target in enumerate(scene.targets):
        tau0, alpha = physics.target_delay(scene, target)
        amp = physics.echo_amplitude(scene, target)
        lams = judge.lams(tau0, alpha, amp)
        fidelity, pf = max(((f, float(x.max())) for f, x in lams.items()), key=lambda p: p[1]) if coarse \
            else judge.worst(lams)
        lam = float(lams[fidelity].max())
        fraction = lam / noncentrality(law, scene, amp ** 2 * full_slot) if lam > 0 else 0.0
        if coarse:              # no sample of a tail exceeds the square root of its energy
            peak = math.sqrt(lam * law.sigma_eff ** 2 * scene.n_samples / (law.n_rx * law.dof)) / law.lsb
            leaks.append(Leak(i, target.range_m, target.rcs_m2, fidelity, float(fraction), lam, eta, math.nan,
                              pf_free, judge.limit, math.nan, None, False, peak))
            continue
        spans = _ranges_over(judge, target, alpha) if pf > judge.limit else None
        limit = _rcs_limit(judge, target, lams) if every_limit or pf > judge.limit else math.nan
        leaks.append(Leak(i, target.range_m, target.rcs_m2, fidelity, float(fraction), lam, eta, pf, pf_free,
                          judge.limit, limit, spans))
    return leaks


def _ranges(spans) -> str:
    return ", ".join(f"{a:.3g}-{b:.3g} m" for a, b in spans) or "no range scanned"


def leak_warnings(scene: Scene, eta: float | None = None, *, pf_design: float = PF_WARN,
                  sigma_det: float | None = None, who: str = "C(eta)") -> list[str]:
    """One line per target whose echo leaks enough into the silent slots to raise the false-alarm rate."""
    out = []
    for k in scene_leaks(scene, eta, pf_design=pf_design, sigma_det=sigma_det, every_limit=False):
        if not k.judged and k.peak_steps >= 0.1:
            out.append(f"targets[{k.target}] ({k.range_m:g} m, {k.rcs_m2:g} m^2): up to {k.fraction:.2g} of a slot of "
                       f"its echo leaks into a silent slot after an active one ({k.fidelity} fidelity), up to "
                       f"{k.peak_steps:.3g} ADC steps in a sample; what it does to {who}'s false-alarm rate is not "
                       f"stated: the ADC's step is coarse against the noise ({scene_law(scene).steps():.3g} steps), "
                       "and the leak's law takes quantisation as uniform noise (a later ADC start, t_adc_start_s, "
                       "removes what the ramp's reset leaves)")
        if not k.exceeds:
            continue
        out.append(
            f"targets[{k.target}] ({k.range_m:g} m, {k.rcs_m2:g} m^2): up to {k.fraction:.2g} of a slot of its echo "
            f"leaks into a silent slot after an active one ({k.fidelity} fidelity, up to "
            f"{10 * math.log10(k.lam):+.1f} dB over the slot's noise as the Doppler turns its phase), so {who} at "
            f"eta = {k.eta:.4g} alarms on {k.pf:.2g} of attack-free cycles "
            f"({k.pf_free:.2g} without it; warned above {k.limit:.2g}). Within that: below {k.rcs_limit_m2:.3g} m^2 at "
            f"{k.range_m:g} m; at {k.rcs_m2:g} m^2 it exceeds at {_ranges(k.ranges_over)} (a later ADC start, "
            "t_adc_start_s, removes what the ramp's reset leaves)")
    return out
