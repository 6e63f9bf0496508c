"""Cycle source backed by the radar signal chain (`carav_stream.radar`): any attacker model, any scene.

    samples  simulate_cycles(scene, rho, rng_noise, attacker=..., rng_attack=...) -> chirp_rms -> Q
    energy   exact sufficient statistics (see `paper_model.sample_rms`) when the scene allows it: no, random or
             smart attack, beat fidelity, Swerling 0 targets, ideal ADC (adc_bits = 0; quantisation and clipping
             make the samples non-Gaussian). The echo of chirp k is then rho(k) x_k with x_k the chain's own echo
             template, so the paper model with that echo is the same law.

Activation: "seeded" (default, simulation) draws uniformly random balanced rows from the batch's generator, the same
law as the firmware's secure source; "lfsr" and "secure" use `ActivationSource` (needed against lfsr_predictor).
Attackers are stateful (they listen to past cycles), so one attacker object serves a whole (attack, RARMS) job and
its batches run in order.
A scene with a receiver array (`getattr(scene, "n_rx", 1)` > 1: frames (n_cycles, n_rx, n_chirps, n_samples)) is
judged on each chirp's RMS over all its receivers; every sample is simulated, the closed form is the attack-free one
(nu -> n_rx nu; the chain steers the attack as its channel does), and the opt-in detectors, which take one
receiver's frames, are refused.
"""
from __future__ import annotations

import numpy as np

from carav_stream.detect.detector import chirp_rms, detect_from_rms
from carav_stream.montecarlo import paper_model
from carav_stream.montecarlo.detectors import statistic
from carav_stream.radar.activation import ActivationSource, balanced_rows
from carav_stream.radar.adc import output_noise_rms
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.physics import echo_templates
from carav_stream.radar.synth import resolve_fidelity, simulate_cycles

__all__ = ["RadarSource", "ENERGY_ATTACKS"]

ENERGY_ATTACKS = ("none", "random", "smart")


class RadarSource:
    """Cycle source over a `carav_stream.radar.scene.Scene`.

    attack_params  {kind: {param: value}} extra attacker parameters (e.g. {"ghost": {"range_m": 25.0}})
    activation     "seeded" | "lfsr" | "secure"
    detector_sigma_n  noise RMS the detector uses (default: the scene's true sigma_n); set it to model a drift
    fidelity       "auto" (beat unless the attacker transmits its own waveform), "beat" or "waveform": the
                   waveform fidelity renders what the beat fidelity leaves out (the IF filter, the previous
                   chirp's echo at a slot's start), so every cycle is simulated sample by sample (no energy
                   shortcut, no closed form)
    """

    sequential = True

    def __init__(self, scene, *, attack_params: dict | None = None, activation: str = "seeded",
                 activation_seed: int = 1, detector_sigma_n: float | None = None, fidelity: str = "auto"):
        resolve_fidelity(fidelity)          # ValueError naming it if unknown
        self.fidelity = fidelity
        self.scene = scene
        self.name = scene.name
        self.n_chirps, self.n_samples, self.iq = scene.n_chirps, scene.n_samples, scene.iq
        self.n_rx = int(getattr(scene, "n_rx", 1))
        # sigma_n the detector was calibrated with; differs from the scene's true noise to model a drift
        self.sigma_n = scene.sigma_n if detector_sigma_n is None else float(detector_sigma_n)
        # the opt-in tests' fixed PF 1e-6 thresholds hold for the noise the ADC delivers: calibrated to it (C's
        # eta is designed with the quantisation in its law instead), unless a drift is modelled
        self.opt_in_sigma = output_noise_rms(scene) if detector_sigma_n is None else self.sigma_n
        self.attack_params = {k: dict(v) for k, v in (attack_params or {}).items()}
        if activation not in ("seeded", "lfsr", "secure"):
            raise ValueError(f"activation: unknown {activation!r}, expected seeded, lfsr or secure")
        self.activation = activation
        self.activation_seed = activation_seed
        self._job = None
        self._paper = None

    # -- helpers -------------------------------------------------------------------------------------------------
    def paper_equivalent(self) -> paper_model.PaperScene:
        """The paper-model scene with this scene's beat-fidelity echo template (for the energy path)."""
        if self._paper is None:
            tpl = echo_templates(self.scene, "beat")
            echo = tpl.main_sum.astype(np.complex128 if self.iq else np.float64)
            self._paper = paper_model.PaperScene(self.name, self.n_chirps, self.n_samples, self.iq,
                                                 self.scene.sigma_n, echo)
        return self._paper

    def make_attacker(self, attack: str, rarms: float):
        if attack == "none":
            return None
        params = dict(self.attack_params.get(attack, {}))
        if attack == "ramp":
            params.setdefault("rarms_end", rarms)
        elif attack == "secondary_antenna":
            if "tx_power_w" not in params:
                # choose the transmit power that gives the requested per-sample RMS at the ADC (amplitude ~ sqrt(P))
                probe = make_attacker(attack, self.scene, **params, tx_power_w=1e-3)
                rms_probe = probe.amplitude() / (1.0 if self.iq else np.sqrt(2.0))
                params["tx_power_w"] = 1e-3 * (rarms * self.scene.sigma_n / rms_probe) ** 2
        else:
            params.setdefault("rarms", rarms)
        return make_attacker(attack, self.scene, **params)

    # -- CycleSource protocol ----------------------------------------------------------------------------------
    def energy_exact(self, attack: str) -> bool:
        s = self.scene
        return (attack in ENERGY_ATTACKS and s.adc_bits == 0 and all(t.swerling == 0 for t in s.targets)
                and not s.attackers and self.sigma_n == s.sigma_n and self.fidelity != "waveform" and self.n_rx == 1)

    def closed_form(self, attack: str) -> dict | None:
        if self.sigma_n != self.scene.sigma_n or self.fidelity == "waveform":
            return None
        if attack not in ("none", "random") or self.scene.adc_bits != 0 or any(t.swerling for t in self.scene.targets):
            return None
        if self.n_rx > 1 and attack != "none":
            return None
        pm = self.paper_equivalent()
        if not paper_model.exchangeable(pm, "none"):
            return None
        if self.n_rx > 1:
            return {"n_chirps": self.n_chirps, "dof": pm.dof, "snr": pm.echo_snr, "n_rx": self.n_rx}
        return {"n_chirps": self.n_chirps, "dof": pm.dof, "snr": pm.echo_snr}

    def begin_job(self, attack: str, rarms: float) -> None:
        """Start a fresh (attack, RARMS) job: new attacker, activation stream and cycle counter."""

        act = None
        if self.activation == "lfsr":
            act = ActivationSource("lfsr", seed=self.activation_seed)
        elif self.activation == "secure":
            act = ActivationSource("secure")
        self._job = {"attacker": self.make_attacker(attack, rarms), "activation": act, "cycle0": 0,
                     "key": (attack, rarms), "clipped": 0, "samples": 0}

    def draw(self, n_cycles, attack, rarms, rng, method):
        if method == "energy":
            pm = self.paper_equivalent()
            rho = balanced_rows(rng, n_cycles, self.n_chirps, self.scene.n_slots)
            return paper_model.sample_rms(pm, rho, rng, attack, rarms), rho
        frames, rho = self.draw_frames(n_cycles, attack, rarms, rng)
        return chirp_rms(frames, receivers=self.n_rx > 1), rho

    def draw_stat(self, n_cycles, attack, rarms, rng, detector: str):
        """An opt-in detector's statistic (carav_stream.montecarlo.detectors) on n_cycles full-sample cycles (a
        receiver array's judged over all its receivers)."""

        frames, rho = self.draw_frames(n_cycles, attack, rarms, rng)
        return statistic(detector, frames, rho, self.opt_in_sigma, self.scene)

    def draw_frames(self, n_cycles, attack, rarms, rng):
        """Every sample of n_cycles cycles of the current job (its attacker, activation and cycle count)."""

        if self._job is None or self._job["key"] != (attack, rarms):
            self.begin_job(attack, rarms)
        job = self._job
        if job["activation"] is None:       # drawn per TDM loop, as the radar's firmware draws it
            rho = balanced_rows(rng, n_cycles, self.n_chirps, self.scene.n_slots)
        else:
            rho = job["activation"].next(n_cycles, self.n_chirps, self.scene.n_slots)
        rng_attack = np.random.default_rng(rng.integers(2 ** 63))
        cyc = simulate_cycles(self.scene, rho, rng, attacker=job["attacker"], rng_attack=rng_attack,
                              fidelity=self.fidelity, cycle0=job["cycle0"])
        job["cycle0"] += n_cycles
        job["clipped"] += int(cyc.clipped.sum())
        job["samples"] += cyc.frames.size
        return cyc.frames, rho

    def draw_q(self, n_cycles, attack, rarms, rng, method):
        if method == "energy" and self.energy_exact(attack) and paper_model.exchangeable(self.paper_equivalent(),
                                                                                         attack):
            return paper_model.sample_q_fast(self.paper_equivalent(), n_cycles, rng, attack, rarms)
        rms, rho = self.draw(n_cycles, attack, rarms, rng, method)
        det = detect_from_rms(rms, rho, self.sigma_n, 1.0)
        return det.q, det.by_d1

    def describe(self) -> dict:
        s = self.scene
        out = {"model": "radar", "name": s.name, "n_chirps": s.n_chirps, "n_samples": s.n_samples, "iq": s.iq,
               "sigma_n": s.sigma_n, "adc_bits": s.adc_bits, "activation": self.activation,
               "fidelity": self.fidelity}
        if self.n_rx > 1:
            out["n_rx"] = self.n_rx
        if s.targets:
            out["snr_db"] = s.snr_db(0)
        return out
