"""Detection thresholds of a scene for a target false-alarm rate per cycle (pure functions: a Scene in, numbers out).

The RMS detector's C(eta) has no universal threshold: its false-alarm rate per cycle depends on the scene's chirps per
cycle N_r (M = N_r / 2 silent chirps, each a chance to cross), samples per chirp N_s (the spread of a chirp's RMS,
1 / sqrt(2 nu)), I-only or I/Q (nu = N_s or 2 N_s real degrees of freedom) and, through D1, the echo. eta = 1.5
gives about 5e-104 per cycle on table1 (nu = 1080), 7e-25 on awr1642 (nu = 256) and 8e-3 on a 256-chirp,
32-sample I-only scene (`carav design`).

Model: white Gaussian noise of the scene's sigma_n plus the ADC's quantisation noise (lsb^2 / 12 per real
component, `carav_stream.radar.adc.output_noise_rms`; exact in the limit sigma_n >> lsb, which the presets' cars
satisfy by orders of magnitude; the table1 car at 5 m, whose echo lifts the full scale, gives lsb = 1.5 sigma_n),
a constant echo (the beat-fidelity template, as `carav_stream.montecarlo.radar_source` uses for its closed form).
D0's law is exact (chi-square), D1's the closed form's quadrature (`carav_stream.detect.stats.pf_pm_closed_form`).
ADC clipping and fluctuating targets are not in the law: see the nuisance table of docs/REPRODUCTION.md for what
they do.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from carav_stream.detect.stats import pf_pm_closed_form
from carav_stream.montecarlo.paper_model import PaperScene
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.adc import output_noise_rms

__all__ = ["SceneLaw", "scene_law", "pf_per_cycle", "pm_random", "rms_threshold", "threshold_warning", "PF_WARN"]

PF_WARN = 1e-6        # a detector threshold above this false-alarm rate per cycle is worth a warning


@dataclass(frozen=True)
class SceneLaw:
    """What the detector's null law depends on.

    n_chirps  N_r;  dof  nu, real samples per chirp;  snr  echo power / noise power at the ADC output
    sigma_n   the scene's analogue noise RMS per sample (what the detector is calibrated with by default)
    sigma_eff noise RMS at the ADC output: sqrt(sigma_n^2 + lsb^2 / 12) (= sigma_n for an ideal ADC)
    """

    name: str
    n_chirps: int
    dof: int
    snr: float
    sigma_n: float
    sigma_eff: float


def scene_law(scene) -> SceneLaw:
    """The law of a radar Scene (beat-fidelity echo, its ADC) or of a paper-model PaperScene (no ADC)."""

    if isinstance(scene, PaperScene):
        return SceneLaw(scene.name, scene.n_chirps, scene.dof, scene.echo_snr, scene.sigma_n, scene.sigma_n)
    pm = RadarSource(scene).paper_equivalent()      # the echo template and nu, as the closed form sees them
    sigma_eff = output_noise_rms(scene)
    snr = pm.echo_snr * (scene.sigma_n / sigma_eff) ** 2
    return SceneLaw(scene.name, scene.n_chirps, pm.dof, float(snr), float(scene.sigma_n), sigma_eff)


def _gauss(law: SceneLaw, eta, sigma_det: float | None, rarms: float = 0.0) -> dict:
    """The closed form in units of the ADC's output noise: D0 = ||R|| / sigma_det = (sigma_eff / sigma_det) chi."""
    scale = (sigma_det or law.sigma_n) / law.sigma_eff
    return pf_pm_closed_form(np.asarray(eta, dtype=np.float64) * scale, n_chirps=law.n_chirps, dof=law.dof,
                             snr=law.snr, rarms=rarms * law.sigma_n / law.sigma_eff)


def pf_per_cycle(law: SceneLaw, eta, sigma_det: float | None = None) -> np.ndarray:
    """P(C(eta) alarms on an attack-free cycle), D0 and D1; sigma_det: the detector's sigma_n (default the scene's)."""
    return _gauss(law, eta, sigma_det)["p_alarm"]


def pm_random(law: SceneLaw, eta, rarms: float, sigma_det: float | None = None) -> np.ndarray:
    """P(no alarm) under the `random` attack of the given RARMS (i.i.d. Gaussian, RMS RARMS * sigma_n)."""
    return _gauss(law, eta, sigma_det, rarms)["p_quiet"]


def rms_threshold(law: SceneLaw, pf: float, sigma_det: float | None = None) -> float:
    """eta with PF(eta) = pf per cycle (D0 and D1), by root search on log PF (PF falls monotonically in eta)."""
    if not 0 < pf < 1:
        raise ValueError(f"pf: must be in (0, 1), got {pf!r}")

    def f(eta: float) -> float:
        return math.log(max(float(pf_per_cycle(law, eta, sigma_det)), 1e-300)) - math.log(pf)

    lo, hi = 1e-3, 2.0
    while f(hi) > 0:            # widen until PF(hi) < pf (PF falls like a Gaussian tail in eta^2 nu)
        lo, hi = hi, hi * 2
        if hi > 1e6:
            raise ValueError(f"no threshold reaches PF {pf:g} per cycle for scene {law.name}")
    return float(optimize.brentq(f, lo, hi, xtol=1e-10, rtol=1e-12))


def threshold_warning(law: SceneLaw, eta: float, sigma_det: float | None = None, *, who: str = "C(eta)",
                      design_hint: str = "carav design") -> str | None:
    """One line when eta raises false alarms on more than PF_WARN of attack-free cycles of the scene, else None."""
    pf = float(pf_per_cycle(law, eta, sigma_det))
    if pf <= PF_WARN:
        return None
    return (f"{who} eta = {eta:g} raises false alarms on {pf:.2g} of attack-free cycles of scene {law.name} "
            f"(N_r = {law.n_chirps}, nu = {law.dof}; above {PF_WARN:g}); `{design_hint}` gives "
            f"eta = {rms_threshold(law, PF_WARN, sigma_det):.4g} for {PF_WARN:g}")
