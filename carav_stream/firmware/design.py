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
Where the ADC's step exceeds 1.5 x the noise of a component (sigma_c / lsb < QUANTISED_BELOW; the table1 car at 3 m:
lsb = 4.1 sigma_n), most silent samples quantise to 0 and the silent chirps' RMS falls below sigma_n instead of rising
with lsb^2 / 12: D0's law is then the quantised noise's own, exactly (`carav_stream.detect.quantised`; from
sigma_c = 0.65 lsb up, the uniform model's eta for 1e-6 on table1 is within 0.1 % of it, 0.6 % at 0.5 lsb), and D1's
keeps the uniform model (the echo, many steps high, dithers its quantisation). Being discrete, that law moves in
steps of the chirp's energy in codes: a threshold is where PF jumps past the target.
ADC clipping and fluctuating targets are not in the law: see the nuisance table of docs/REPRODUCTION.md for what
they do.
A receiver array (`getattr(scene, "n_rx", 1)` receivers, or the n_rx given to `scene_law`): the detector judges each
chirp's RMS over all its receivers' samples, whose law is the one receiver's with N_s -> n_rx N_s (independent
noise per receiver, the echo steered with unit modulus: carav_stream/detect/receivers.py), so PF and the threshold
are those of n_rx times the samples. The `random` attack of `pm_random` is one attacker's signal on every receiver,
steered with unit modulus: its law is the one receiver's only for n_rx = 1 (`SceneLaw.attack_gains`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from carav_stream.detect.quantised import quantised_energy_logsf
from carav_stream.detect.receivers import receiver_count
from carav_stream.detect.stats import pf_pm_closed_form
from carav_stream.montecarlo.paper_model import PaperScene
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.adc import adc_step, output_noise_rms

__all__ = ["SceneLaw", "scene_law", "pf_per_cycle", "pm_random", "rms_threshold", "threshold_warning", "PF_WARN"]

PF_WARN = 1e-6        # a detector threshold above this false-alarm rate per cycle is worth a warning
QUANTISED_BELOW = 0.65  # sigma_c / lsb below which D0's law is the quantised noise's (detect/quantised.py)


@dataclass(frozen=True)
class SceneLaw:
    """What the detector's null law depends on.

    n_chirps  N_r;  dof  nu, real samples per chirp;  snr  echo power / noise power at the ADC output
    sigma_n   the scene's analogue noise RMS per sample (what the detector is calibrated with by default)
    sigma_eff noise RMS at the ADC output: sqrt(sigma_n^2 + lsb^2 / 12) (= sigma_n for an ideal ADC)
    lsb       the ADC's step (0: an ideal ADC);  iq  I/Q samples (nu = 2 N_s components of sigma_n / sqrt(2))
    n_rx      receivers, the detector on each chirp's RMS over all of them (nu per receiver, n_rx nu in all)
    """

    name: str
    n_chirps: int
    dof: int
    snr: float
    sigma_n: float
    sigma_eff: float
    lsb: float = 0.0
    iq: bool = False
    n_rx: int = 1

    @property
    def attack_gains(self) -> tuple[float, ...] | None:
        """The steering gains of the `random` attack's law (carav_stream/detect/receivers.py): None for one receiver;
        one attacker on n_rx receivers at broadside otherwise, (n_rx,): the law of I/Q at every angle, and of I-only
        where the receivers' phases agree modulo pi."""
        return None if self.n_rx == 1 else (float(self.n_rx),)

    def steps(self, rarms: float = 0.0) -> float:
        """sigma_c / lsb: a silent component's noise (under the `random` attack of RARMS) in ADC steps (inf: ideal)."""
        if not self.lsb:
            return math.inf
        return self.sigma_n * math.sqrt((1.0 + rarms ** 2) / (2.0 if self.iq else 1.0)) / self.lsb


def scene_law(scene, n_rx: int | None = None) -> SceneLaw:
    """The law of a radar Scene (beat-fidelity echo, its ADC) or of a paper-model PaperScene (no ADC), for n_rx
    receivers (default the scene's own: `getattr(scene, "n_rx", 1)`)."""

    n_rx = receiver_count(getattr(scene, "n_rx", 1) if n_rx is None else n_rx)
    if isinstance(scene, PaperScene):
        return SceneLaw(scene.name, scene.n_chirps, scene.dof, scene.echo_snr, scene.sigma_n, scene.sigma_n,
                        n_rx=n_rx)
    pm = RadarSource(scene).paper_equivalent()      # the echo template and nu, as the closed form sees them
    sigma_eff = output_noise_rms(scene)
    snr = pm.echo_snr * (scene.sigma_n / sigma_eff) ** 2
    return SceneLaw(scene.name, scene.n_chirps, pm.dof, float(snr), float(scene.sigma_n), sigma_eff,
                    float(adc_step(scene) or 0.0), bool(scene.iq), n_rx)


def _gauss(law: SceneLaw, eta, sigma_det: float | None, rarms: float = 0.0) -> dict:
    """The closed form in units of the ADC's output noise: D0 = ||R|| / sigma_det = (sigma_eff / sigma_det) chi; D0's
    part from the quantised noise's law where the ADC's step exceeds the noise."""
    eta = np.asarray(eta, dtype=np.float64)
    scale = (sigma_det or law.sigma_n) / law.sigma_eff
    out = pf_pm_closed_form(eta * scale, n_chirps=law.n_chirps, dof=law.dof, snr=law.snr,
                            rarms=rarms * law.sigma_n / law.sigma_eff, n_rx=law.n_rx, attack_gains=law.attack_gains)
    r = law.steps(rarms)
    if r >= QUANTISED_BELOW:
        return out
    # D0 >= eta  <=>  the chirp's energy in codes S >= s* = N_s eta^2 sigma_det^2 / lsb^2, over every receiver's
    # N_s samples (the quantised law takes the components as independent: exact without an attack)
    n_s = law.n_rx * (law.dof // 2 if law.iq else law.dof)
    log_sf = np.minimum(quantised_energy_logsf(n_s * (eta * (sigma_det or law.sigma_n) / law.lsb) ** 2,
                                               law.n_rx * law.dof, r), 0.0)
    with np.errstate(divide="ignore"):
        log_cdf = np.where(log_sf < -0.7, np.log1p(-np.exp(log_sf)), np.log(-np.expm1(np.minimum(log_sf, -1e-300))))
        m = law.n_chirps // 2
        log_quiet = m * log_cdf + np.log(np.maximum(out["quiet_d1"], 1e-300))
    return {**out, "quiet_d0": np.exp(m * log_cdf), "p_alarm_d0": -np.expm1(m * log_cdf),
            "p_quiet": np.exp(log_quiet), "p_alarm": -np.expm1(log_quiet)}


def pf_per_cycle(law: SceneLaw, eta, sigma_det: float | None = None) -> np.ndarray:
    """P(C(eta) alarms on an attack-free cycle), D0 and D1; sigma_det: the detector's sigma_n (default the scene's)."""
    return _gauss(law, eta, sigma_det)["p_alarm"]


def pm_random(law: SceneLaw, eta, rarms: float, sigma_det: float | None = None) -> np.ndarray:
    """P(no alarm) under the `random` attack of the given RARMS (i.i.d. Gaussian, RMS RARMS * sigma_n)."""
    return _gauss(law, eta, sigma_det, rarms)["p_quiet"]


def rms_threshold(law: SceneLaw, pf: float, sigma_det: float | None = None) -> float:
    """eta with PF(eta) = pf per cycle (D0 and D1), by root search on log PF (PF falls monotonically in eta); where PF
    jumps past pf (the quantised law), the first eta at which it is below."""
    if not 0 < pf < 1:
        raise ValueError(f"pf: must be in (0, 1), got {pf!r}")

    def f(eta: float) -> float:
        return math.log(max(float(pf_per_cycle(law, eta, sigma_det)), 1e-300)) - math.log(pf)

    lo, hi = 1e-3, 2.0
    while f(hi) > 0:            # widen until PF(hi) < pf (PF falls like a Gaussian tail in eta^2 nu)
        lo, hi = hi, hi * 2
        if hi > 1e6:
            raise ValueError(f"no threshold reaches PF {pf:g} per cycle for scene {law.name}")
    eta = float(optimize.brentq(f, lo, hi, xtol=1e-10, rtol=1e-12))
    # the quantised law moves in steps: the root is a jump, and the threshold the first eta past it
    return eta if f(eta) <= 0 else min(hi, eta * (1 + 4e-12) + 2e-10)


def threshold_warning(law: SceneLaw, eta: float, sigma_det: float | None = None, *, who: str = "C(eta)",
                      design_hint: str = "carav design") -> str | None:
    """One line when eta raises false alarms on more than PF_WARN of attack-free cycles of the scene, else None."""
    pf = float(pf_per_cycle(law, eta, sigma_det))
    if pf <= PF_WARN:
        return None
    nu = f"nu = {law.dof}" if law.n_rx == 1 else f"nu = {law.dof} per receiver, {law.n_rx} receivers"
    return (f"{who} eta = {eta:g} raises false alarms on {pf:.2g} of attack-free cycles of scene {law.name} "
            f"(N_r = {law.n_chirps}, {nu}; above {PF_WARN:g}); `{design_hint}` gives "
            f"eta = {rms_threshold(law, PF_WARN, sigma_det):.4g} for {PF_WARN:g}")
