"""Attack signal models a_k[m] (paper Sections IV, V.D-V.G, plus physical spoofers).

``make_attacker(kind, scene, **params)`` builds one. ``attacker.apply(rx, cycle0, rng_attack,
observation, fidelity=...)`` returns ``(rx + a, attack_active)``; ``emit`` returns ``(a, attack_active)``
without ever looking at rx. No attacker is given the activation sequence: ``observation`` is the
victim's on-air emission, and the base class hands an attacker row i only *after* it has produced
cycle i (``_listen``), except the reactive repeater, whose output in a chirp is the victim's own
signal delayed by its reaction latency (zero on silent chirps). Attackers are stateful (what they
have heard); use one object for consecutive batches, in cycle order.

The reactive repeater is two pure steps, so that a receiver can model its physics without the attacker
ever knowing rho: ``ReactiveAttacker.response(fidelity)`` is what it answers to a chirp (independent of
rho), and :func:`gate_by_emission` keeps the answers to the chirps actually on the air. ``emit`` runs both;
the pipeline's attacker node sends the response and its receiver (adc_framer) gates it.

Common parameters: ``start_cycle`` (int, default 0) and ``n_active_cycles`` (int or None = forever).
RMS levels are ``rarms`` = sigma_a / sigma_n, per-sample RMS while on (E|a|^2 = sigma_a^2, for I-only
and I/Q alike).

kinds and their own parameters
    none                no attack.
    random              i.i.d. Gaussian samples, ``rarms`` (V.D).
    smart               one Gaussian sequence of n_samples per cycle, repeated in every chirp, ``rarms`` (V.E).
    ramp                random (or ``pattern = "smart"``) attack whose RARMS rises linearly from
                        ``rarms_start`` to ``rarms_end`` over ``n_ramp_cycles`` cycles, then stays.
    lfsr_predictor      listens to past cycles' emission, fits the shortest LFSR (Berlekamp-Massey over
                        the Manchester bits, last ``max_history_bits``) and puts Gaussian noise at
                        ``rarms`` on the chirps it predicts active only.
    ghost               chirp-synchronised spoofer (knows the victim's timing and slope, not rho): in
                        every chirp period a replica of the victim's chirp delayed and Doppler-shifted to
                        look like a target at ``range_m`` with ground speed ``velocity_mps`` (target
                        convention), per-sample RMS ``rarms``.
    reactive            repeater at ``distance_m`` (ground speed ``velocity_mps``) that re-emits each
                        victim chirp after a reaction latency ``latency_s``: delay 2 d / c + L, silent on
                        silent chirps, RMS ``rarms`` while on.
    secondary_antenna   a physical FMCW transmitter at ``range_m`` moving at ``velocity_mps`` (default
                        50 km/h), power ``tx_power_w``, gain ``tx_gain_db``, its own sweep
                        (``slope_hz_per_s``, ``t_sweep_s``, ``t_chirp_s``, default the victim's; start
                        ``t_offset_s``; its sweeps start at fc + ``f_offset_hz``), received one way through the
                        victim's antenna and receive chain (V.G). Needs ``waveform`` fidelity.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from carav_stream.core.params import Param, problems, suggest
from carav_stream.core.units import C_MPS, KMH
from carav_stream.radar import physics
from carav_stream.radar.activation import berlekamp_massey, lfsr_continue
from carav_stream.radar.noise import gaussian
from carav_stream.radar.scene import Scene


@dataclass(frozen=True)
class Observation:
    """What an attacker can physically observe of the victim: the on-air emission.

    Attackers must only use row i of ``emission`` when emitting for cycles after cycle0 + i (they
    listen to a cycle, then act on later ones); the reactive repeater may use the current row, but
    only through a reaction latency (its output in a chirp starts L after that chirp reached it).
    The activation sequence itself is never given to an attacker.
    """

    emission: np.ndarray   # bool (n_cycles, n_chirps), as heard on the air
    cycle0: int


def _rarms(default: float = 3.0) -> Param:
    return Param("rarms", float, default, "attack RMS over noise RMS, sigma_a / sigma_n, while on", low=0.0)


class AttackerError(ValueError):
    """All problems with an attacker's parameters: ``problems`` is a list of (param, message)."""

    def __init__(self, kind: str, problems: list[tuple[str, str]]):
        self.kind, self.problems = kind, problems
        super().__init__(f"attacker {kind!r}: " + "; ".join(f"{p}: {m}" if p else m for p, m in problems))


class Attacker:
    """Base class. Subclasses declare their own ``params`` (like block parameters) and implement ``_cycle``."""

    kind = "none"
    needs_waveform = False       # transmits its own waveform: only the waveform fidelity renders it
    uses_live_emission = False   # reacts to the current chirp (with a latency)
    same_every_chirp = False     # a[c, k, :] is the same for every chirp k (a[:, :1] says it all)
    params: tuple[Param, ...] = ()
    COMMON = (Param("start_cycle", int, 0, "first cycle the attacker is on", unit="cycles", low=0),
              Param("n_active_cycles", int, None, "cycles it stays on (none: until the end)", unit="cycles", low=0,
                    optional=True))

    @classmethod
    def declared(cls) -> tuple[Param, ...]:
        """Every parameter the model takes: the common ones and its own."""
        return cls.COMMON + cls.params

    def __init__(self, scene: Scene, **params):
        self.scene = scene
        declared = self.declared()
        found = problems(declared, params, f"attacker {self.kind!r}")
        for p in declared:
            setattr(self, p.name, p.check(params[p.name])[0] if p.name in params else p.default)
        if not found:
            found = self._validate()
        if found:
            raise AttackerError(self.kind, found)
        self.dtype = np.complex64 if scene.iq else np.float32

    def _validate(self) -> list[tuple[str, str]]:
        return []

    # -- interface ------------------------------------------------------------------------------
    def is_on(self, cycle: int) -> bool:
        if cycle < self.start_cycle:
            return False
        return self.n_active_cycles is None or cycle < self.start_cycle + self.n_active_cycles

    def on_cycles(self, n_cycles: int, cycle0: int) -> np.ndarray:
        """bool (n_cycles,): whether the model is switched on in cycles cycle0 .. cycle0 + n_cycles - 1."""
        return np.array([self.is_on(cycle0 + i) for i in range(n_cycles)], dtype=bool)

    def peak_amplitude(self) -> float:
        """Expected peak |a| (about 3 RMS for Gaussian signals) for the ADC-saturation check."""
        return 0.0

    def physics_warnings(self) -> list[str]:
        """Legal but doubtful settings, explained (collected into ``Scene.warnings``)."""
        return []

    def apply(self, rx: np.ndarray, cycle0: int, rng_attack: np.random.Generator | None,
              observation: Observation | None = None, *, fidelity: str = "beat") -> tuple[np.ndarray, np.ndarray]:
        """rx + a for cycles cycle0 .. cycle0 + n - 1 (in place, or a new array if rx is read-only),
        and attack_active bool (n,). ``observation`` is the victim's on-air emission for the same
        cycles (``synth.observe(tx)``; in a pipeline, the source's emission port), never rho itself:
        the attacker hears row i only after producing cycle i (the reactive repeater: within the
        chirp, after its latency). rx is only added to, never read."""
        a, active = self.emit(rx.shape[0], cycle0, rng_attack, observation, fidelity=fidelity)
        out = rx if rx.flags.writeable else rx.copy()
        if a is not None:
            out += a
        return out, active

    def emit(self, n_cycles: int, cycle0: int, rng_attack: np.random.Generator | None,
             observation: Observation | None = None, *, fidelity: str = "beat", compact: bool = False):
        """The attack signal a: (n_cycles, n_chirps, n_samples) of the scene's dtype, or None when
        silent throughout, and attack_active bool (n_cycles,). Draws from rng_attack in cycle order.
        With ``compact`` a model that sends the same samples in every chirp (``same_every_chirp``)
        returns them once per cycle, (n_cycles, 1, n_samples), which broadcasts over the chirps.

        A listening model (``listens``) hears ``observation``'s row i after producing cycle i; with
        ``observation=None`` it hears nothing here (a streaming node feeds it with ``listen``)."""
        on = self.on_cycles(n_cycles, cycle0)
        if self.uses_live_emission and observation is None:
            raise ValueError(f"attacker {self.kind!r} needs observation= (the victim's on-air emission)")
        if observation is not None and (observation.cycle0 != cycle0 or observation.emission.shape[0] != n_cycles):
            raise ValueError(f"attacker {self.kind!r}: observation covers cycles {observation.cycle0}.."
                             f"{observation.cycle0 + observation.emission.shape[0] - 1}, expected "
                             f"{cycle0}..{cycle0 + n_cycles - 1}")
        hear = self._listens and observation is not None
        if not on.any() and not hear:
            return None, on
        rows = 1 if compact and self.same_every_chirp else self.scene.n_chirps
        a = np.zeros((n_cycles, rows, self.scene.n_samples), self.dtype)
        active = np.zeros(n_cycles, dtype=bool)
        batch = self._batch(a, on, cycle0, rng_attack, fidelity)
        for i in range(n_cycles):
            if not batch and on[i]:
                live = observation.emission[i] if self.uses_live_emission else None
                active[i] = self._cycle(a[i], cycle0 + i, rng_attack, live, fidelity)
            elif batch:
                active[i] = on[i]
            if hear:
                self._listen(np.array(observation.emission[i], dtype=bool))
        return a, active

    @property
    def listens(self) -> bool:
        """True if the model learns from past cycles' emission (feed it with ``listen``)."""
        return self._listens

    def listen(self, emission_row) -> None:
        """Hear one past cycle's on-air emission (bool (n_chirps,)) -- for a streaming attacker node
        that gets the emission one cycle late and calls ``emit(1, cycle, rng, None)`` itself."""
        self._listen(np.asarray(emission_row, dtype=bool))

    # -- for subclasses ---------------------------------------------------------------------------
    _listens = False

    def _batch(self, a, on, cycle0, rng, fidelity) -> bool:
        """Fill all cycles at once when that draws the same numbers as cycle by cycle; return True."""
        return False

    def _cycle(self, a_c: np.ndarray, cycle: int, rng, live, fidelity: str) -> bool:
        """Write cycle ``cycle``'s attack into a_c (n_chirps, n_samples); return whether it emitted."""
        return False

    def _listen(self, emission_row: np.ndarray) -> None:
        """Hear one past cycle's emission (bool (n_chirps,)), after producing that cycle."""

    def _gauss(self, rng, shape, rms) -> np.ndarray:
        """Gaussian attack samples, E|a|^2 = rms^2 (one block of rng's stream per leading row)."""
        if rng is None:
            raise ValueError(f"attacker {self.kind!r} draws random numbers: pass rng_attack=")
        return gaussian(rng, tuple(shape), rms, self.scene.iq)


class NoAttacker(Attacker):
    """Silent: never switched on, so every batch is None (no signal to carry between nodes or add at the ADC)."""

    kind = "none"

    def is_on(self, cycle: int) -> bool:
        return False


class RandomAttacker(Attacker):
    kind = "random"
    params = (_rarms(),)

    def peak_amplitude(self):
        return 3.0 * self.rarms * self.scene.sigma_n

    def _batch(self, a, on, cycle0, rng, fidelity):
        if on.any():
            a[on] = self._gauss(rng, (int(on.sum()),) + a.shape[1:], self.rarms * self.scene.sigma_n)
        return True


class SmartAttacker(RandomAttacker):
    kind = "smart"
    same_every_chirp = True

    def _batch(self, a, on, cycle0, rng, fidelity):
        if on.any():
            seq = self._gauss(rng, (int(on.sum()), a.shape[2]), self.rarms * self.scene.sigma_n)
            a[on] = seq[:, None, :]
        return True


class RampAttacker(Attacker):
    kind = "ramp"
    params = (Param("rarms_start", float, 0.5, "RARMS when it switches on", low=0.0),
              Param("rarms_end", float, 5.0, "RARMS it rises to, then keeps", low=0.0),
              Param("n_ramp_cycles", int, 1000, "cycles the rise takes", unit="cycles", low=1),
              Param("pattern", str, "random", "random: i.i.d. samples; smart: one sequence per cycle",
                    choices=("random", "smart")))

    def rarms_at(self, cycle: int) -> float:
        frac = min(max((cycle - self.start_cycle) / self.n_ramp_cycles, 0.0), 1.0)
        return self.rarms_start + (self.rarms_end - self.rarms_start) * frac

    def peak_amplitude(self):
        return 3.0 * max(self.rarms_start, self.rarms_end) * self.scene.sigma_n

    def _batch(self, a, on, cycle0, rng, fidelity):
        idx = np.flatnonzero(on)
        if idx.size:
            shape = (idx.size,) + (a.shape[1:] if self.pattern == "random" else (a.shape[2],))
            z = self._gauss(rng, shape, 1.0)
            scale = np.array([self.rarms_at(cycle0 + i) for i in idx], dtype=np.float32) * self.scene.sigma_n
            z *= scale.reshape((-1,) + (1,) * (z.ndim - 1)).astype(np.float32)
            a[idx] = z if self.pattern == "random" else z[:, None, :]
        return True


class LfsrPredictorAttacker(Attacker):
    kind = "lfsr_predictor"
    params = (_rarms(), Param("max_history_bits", int, 1024, "emission bits it keeps to fit the LFSR", unit="bits",
                              low=1))
    _listens = True

    def __init__(self, scene, **params):
        super().__init__(scene, **params)
        self.history: list[int] = []
        self.model: tuple[int, tuple[int, ...]] = (0, ())
        self.prediction: np.ndarray | None = None     # predicted rho of the next cycle
        self.n_chirps_predicted = 0
        self.n_chirps_correct = 0

    def peak_amplitude(self):
        return 3.0 * self.rarms * self.scene.sigma_n

    def predict(self) -> np.ndarray:
        """Predicted activation row of the next cycle from the LFSR model (Manchester pairs)."""
        length, taps = self.model
        n_bits = self.scene.n_chirps // 2
        if taps and len(self.history) >= max(taps):
            bits = lfsr_continue(self.history[-max(taps):], taps, n_bits)
        else:
            bits = np.zeros(n_bits, dtype=bool)
        rho = np.empty(self.scene.n_chirps, dtype=bool)
        rho[0::2], rho[1::2] = bits, ~bits
        return rho

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        self.prediction = self.predict()
        n_on = int(self.prediction.sum())
        a_c[self.prediction] = self._gauss(rng, (n_on, a_c.shape[1]), self.rarms * self.scene.sigma_n)
        return n_on > 0

    def _listen(self, emission_row):
        predicted = self.prediction if self.prediction is not None else self.predict()
        self.n_chirps_predicted += emission_row.size
        self.n_chirps_correct += int(np.count_nonzero(predicted == emission_row))
        self.prediction = None
        self.history.extend(int(b) for b in emission_row[0::2])
        del self.history[: max(0, len(self.history) - self.max_history_bits)]
        if not np.array_equal(predicted, emission_row):
            self.model = berlekamp_massey(self.history)


class _ReplicaAttacker(Attacker):
    """Shared by ghost and reactive: a delayed replica of the victim's chirp at per-sample RMS rarms."""

    def _replica(self, tau0_s, alpha, gate_from_s, fidelity):
        key = (fidelity,)
        if getattr(self, "_cache_key", None) != key:
            amp = self.rarms * self.scene.sigma_n * (1.0 if self.scene.iq else math.sqrt(2.0))
            if fidelity == "beat":
                main, tail = physics.beat_replica(self.scene, tau0_s, alpha, amp, gate_from_s)
            else:
                main, tail = physics.waveform_replica(self.scene, tau0_s, alpha, amp)
            tail = None if tail is None else tail.astype(self.dtype)
            main = main.astype(self.dtype)
            for x in (main, tail):
                if x is not None:
                    x.setflags(write=False)   # shared by every cycle (and sent by a node without a copy)
            self._cache = (main, tail)
            self._cache_key = key
        return self._cache

    def peak_amplitude(self):
        return self.rarms * self.scene.sigma_n * (1.0 if self.scene.iq else math.sqrt(2.0))


class GhostAttacker(_ReplicaAttacker):
    kind = "ghost"
    params = (Param("range_m", float, 30.0, "range of the false target it plants", unit="m", low=0.0, strict=True),
              Param("velocity_mps", float, 0.0, "ground speed of the false target (target convention)", unit="m/s"),
              _rarms())

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        tau0 = 2.0 * self.range_m / C_MPS
        alpha = 2.0 * (self.velocity_mps - self.scene.radar_speed_mps) / C_MPS
        main, tail = self._replica(tau0, alpha, None, fidelity)
        a_c += main
        if tail is not None:         # it transmits in every chirp period, so every tail is there
            a_c += tail
        return True


class ReactiveAttacker(_ReplicaAttacker):
    kind = "reactive"
    uses_live_emission = True
    params = (Param("distance_m", float, 30.0, "distance of the repeater", unit="m", low=0.0, strict=True),
              Param("velocity_mps", float, 0.0, "ground speed of the repeater (target convention)", unit="m/s"),
              Param("latency_s", float, 1e-7, "reaction latency after a chirp reaches it", unit="s", low=0.0),
              _rarms())

    def delay_s(self) -> float:
        return 2.0 * self.distance_m / C_MPS + self.latency_s

    def _validate(self):
        end = self.scene.t_adc_start_s + self.scene.n_samples / self.scene.fs_hz
        if self.delay_s() >= end:
            return [("latency_s", f"the reply (delay {self.delay_s() * 1e6:.3g} us) starts after the sampling "
                                  f"window ends at {end * 1e6:.3g} us")]
        return []

    def response(self, fidelity: str) -> tuple[np.ndarray, np.ndarray | None]:
        """What it answers in a cycle in which it is on, whatever the victim transmits (rho-independent):
        ``main`` (n_chirps, n_samples), its reply to chirp k heard in chirp k, and ``tail``, its reply to chirp
        k-1 still arriving in chirp k (None at beat fidelity when that spill beats outside the IF band); scene dtype,
        read-only, the same for every cycle. :func:`gate_by_emission` keeps the replies to chirps on air."""
        alpha = 2.0 * (self.velocity_mps - self.scene.radar_speed_mps) / C_MPS
        return self._replica(self.delay_s(), alpha, self.delay_s(), fidelity)

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        main, tail = self.response(fidelity)
        a, active = gate_by_emission(main, tail, np.asarray(live, dtype=bool)[None])
        a_c[...] = a[0]
        return bool(active[0])


def gate_by_emission(main: np.ndarray, tail: np.ndarray | None, on_air: np.ndarray,
                     on: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A repeater's answers kept where the victim's chirps were on the air (the reactive attack a_k[m]).

        a[c, k] = live[c, k] main[k] + live[c, k-1] tail[k]     (k >= 1; chirp 0 gets no tail)
        live[c, k] = on_air[c, k] and on[c]

    main: (n_chirps, n_samples), or (1 | n_cycles, n_chirps, n_samples), from ``ReactiveAttacker.response``;
    tail: the same shape or None (beat fidelity); on_air: bool (n_cycles, n_chirps), chirp k of cycle c was
    transmitted; on: bool (n_cycles,), the repeater is switched on (None = every cycle).
    Returns a, (n_cycles, n_chirps, n_samples) of main's dtype, and attack_active bool (n_cycles,) = a
    chirp of the cycle was answered. Pure; the same floating-point operations for any batch of cycles.
    """
    on_air = np.asarray(on_air)
    if on_air.dtype != np.bool_ or on_air.ndim != 2:
        raise ValueError(f"on_air: expected bool (n_cycles, n_chirps), got {on_air.dtype} {on_air.shape}")
    n_cycles, n_chirps = on_air.shape
    rows = main.shape[-2:]
    if main.ndim not in (2, 3) or rows[0] != n_chirps or main.ndim == 3 and main.shape[0] not in (1, n_cycles):
        raise ValueError(f"main: expected ([1 | {n_cycles},] {n_chirps}, n_samples) for on_air {on_air.shape}, "
                         f"got {main.shape}")
    if tail is not None and (tail.shape != main.shape or tail.dtype != main.dtype):
        raise ValueError(f"tail: expected {main.dtype} {main.shape} like main, got {tail.dtype} {tail.shape}")
    live = on_air
    if on is not None:
        on = np.asarray(on, dtype=bool)
        if on.shape != (n_cycles,):
            raise ValueError(f"on: expected bool ({n_cycles},), got shape {on.shape}")
        live = on_air & on[:, None]
    a = np.zeros((n_cycles,) + rows, main.dtype)
    a[live] += np.broadcast_to(main, a.shape)[live]
    if tail is not None:
        prev = np.zeros_like(live)
        prev[:, 1:] = live[:, :-1]
        a[prev] += np.broadcast_to(tail, a.shape)[prev]
    return a, live.any(axis=1)


class SecondaryAntennaAttacker(Attacker):
    kind = "secondary_antenna"
    needs_waveform = True
    params = (Param("range_m", float, 30.0, "range of the transmitter", unit="m", low=0.0, strict=True),
              Param("velocity_mps", float, 50.0 * KMH, "ground speed of the transmitter (target convention)",
                    unit="m/s"),
              Param("tx_power_w", float, 1e-3, "transmit power", unit="W", low=0.0),
              Param("tx_gain_db", float, 0.0, "transmit antenna gain", unit="dB"),
              Param("slope_hz_per_s", float, None, "its sweep slope (none: the victim's)", unit="Hz/s", low=0.0,
                    strict=True, optional=True),
              Param("t_sweep_s", float, None, "its sweep duration (none: the victim's)", unit="s", low=0.0,
                    strict=True, optional=True),
              Param("t_chirp_s", float, None, "its chirp period (none: the longer of the victim's and its sweep)",
                    unit="s", low=0.0, strict=True, optional=True),
              Param("t_offset_s", float, 0.0, "start of its chirps against the victim's", unit="s"),
              Param("f_offset_hz", float, 0.0, "start frequency of its sweeps above fc", unit="Hz"))

    def __init__(self, scene, **params):
        super().__init__(scene, **params)
        self.slope_hz_per_s = self.slope_hz_per_s or scene.slope_hz_per_s
        self.t_sweep_s = self.t_sweep_s or scene.t_sweep_s
        self.t_chirp_s = self.t_chirp_s or max(scene.t_chirp_s, self.t_sweep_s)
        self._cache: dict = {}
        self._grid_terms: tuple[np.ndarray, np.ndarray] | None = None

    def _validate(self):
        out = []
        t_sweep = self.t_sweep_s or self.scene.t_sweep_s
        t_chirp = self.t_chirp_s or max(self.scene.t_chirp_s, t_sweep)
        if t_chirp < t_sweep:
            out.append(("t_chirp_s", f"must be >= its t_sweep_s {t_sweep:.6g} s, got {t_chirp:.6g}"))
        return out

    def amplitude(self) -> float:
        """Dechirped amplitude: sqrt(Pa Ga Grx lambda^2 / (4 pi R)^2), one-way free space."""
        s = self.scene
        with np.errstate(over="ignore"):
            p_w = (np.float64(self.tx_power_w) * 10 ** (np.float64(self.tx_gain_db) / 10)
                   * 10 ** (s.rx_gain_db / 10) * s.wavelength_m ** 2 / (4 * np.pi * np.float64(self.range_m)) ** 2)
        return float(np.sqrt(p_w))

    def peak_amplitude(self):
        return self.amplitude()

    def equivalent_rarms(self) -> float:
        """sigma_a / sigma_n of its contribution while in band (A for I/Q, A / sqrt 2 for I-only):
        maps transmit power to the paper's RARMS (low / medium / high power cases of V.G)."""
        a = self.amplitude() if self.scene.iq else self.amplitude() / math.sqrt(2.0)
        return a / self.scene.sigma_n

    def physics_warnings(self):
        s = self.scene
        # worst mixer-product frequency on the waveform grid: slope mismatch over a sweep, plus offset
        f_mix = abs(self.slope_hz_per_s - s.slope_hz_per_s) * s.t_sweep_s + abs(self.f_offset_hz)
        nyq = s.waveform_oversample * s.fs_hz / 2
        if f_mix > nyq:
            return [f"its mixer product sweeps up to {f_mix / 1e6:.4g} MHz, beyond the waveform grid's "
                    f"+-{nyq / 1e6:.4g} MHz (waveform_oversample = {s.waveform_oversample}): the parts beyond "
                    f"alias into the IF band; raise waveform_oversample to about {math.ceil(2 * f_mix / s.fs_hz)}"]
        return []

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        if fidelity != "waveform":
            raise ValueError("attacker 'secondary_antenna' transmits its own waveform: use fidelity 'waveform'")
        s = self.scene
        phase0 = (cycle * s.t_cycle_s - self.t_offset_s) % self.t_chirp_s
        key = round(phase0 * 1e15)
        if key not in self._cache:
            if len(self._cache) > 8:
                self._cache.clear()
            self._cache[key] = physics.filter_decimate(s, self.mixed(phase0)).astype(self.dtype)
        a_c += self._cache[key]
        return self.tx_power_w > 0

    def mixed(self, phase0_s: float) -> np.ndarray:
        """The victim's mixer output on the waveform grid, float64 | complex128 (n_chirps, n_grid), in a cycle that
        starts phase0_s seconds into one of its chirp periods (t since the cycle start, R, v: its range and speed):

            tau = (R + (v - v_radar) t) / c,    u = (t - tau + phase0_s) mod t_chirp,    gate = u < t_sweep
            y = A gate exp(j (theta_ref(t) + 2 pi fc tau - (2 pi f_offset u + pi slope u u)))    (Re for I-only)

        t - tau and theta_ref + 2 pi fc tau are the same in every cycle and are kept from the first; the rest runs a
        few chirps at a time (its temporaries stay in cache), the modulo by physics.wrap_s and the exponential only
        under the gate (physics.tone). The values are those of these expressions evaluated on the whole grid with
        numpy in the order written (off the gate a zero whose sign may differ, which the IF filter's sums never
        show), at half the cost: 3.3 ms against 6.8 ms a cycle on table1 for an unsynchronised interferer.
        """
        s = self.scene
        if self._grid_terms is None:
            g = physics.waveform_grid(s)
            tau = (self.range_m + (self.velocity_mps - s.radar_speed_mps) * g.t_cycle_s) / C_MPS
            self._grid_terms = (g.t_cycle_s - tau, g.ref_phase + 2 * np.pi * s.fc_hz * tau)
        lead, carrier = self._grid_terms
        y = np.empty(lead.shape, np.complex128 if s.iq else np.float64)
        amp = self.amplitude()
        c_offset, c_slope = 2 * np.pi * self.f_offset_hz, np.pi * self.slope_hz_per_s
        rows = max(1, 32768 // lead.shape[1])
        for a in range(0, lead.shape[0], rows):
            u = physics.wrap_s(lead[a: a + rows] + phase0_s, self.t_chirp_s)
            gate = u < self.t_sweep_s
            phase = c_slope * u
            phase *= u
            if self.f_offset_hz != 0:            # else 0 u + x = x (u >= 0; where u is NaN, so is x)
                phase += c_offset * u
            np.subtract(carrier[a: a + rows], phase, out=phase)
            physics.tone(s, phase, amp, gate, out=y[a: a + rows])
        return y


KINDS = {cls.kind: cls for cls in (NoAttacker, RandomAttacker, SmartAttacker, RampAttacker, LfsrPredictorAttacker,
                                   GhostAttacker, ReactiveAttacker, SecondaryAntennaAttacker)}


def make_attacker(kind: str, scene: Scene, **params) -> Attacker:
    """Build an attacker of ``kind`` (see the module docstring for each kind's parameters).

    Raises :class:`AttackerError` (a ValueError) listing every bad parameter.
    """
    if kind not in KINDS:
        raise AttackerError(str(kind), [("kind", f"unknown attacker kind {kind!r}{suggest(str(kind), KINDS)}")])
    return KINDS[kind](scene, **params)


class CompositeAttacker(Attacker):
    """Several attackers on the air at once: a = sum of theirs. Runs them cycle by cycle, in list order,
    so that the draws from the shared rng_attack do not depend on the batch size."""

    kind = "composite"

    def __init__(self, scene: Scene, parts: list[Attacker]):
        self.scene, self.parts = scene, list(parts)
        self.needs_waveform = any(p.needs_waveform for p in parts)
        self.uses_live_emission = any(p.uses_live_emission for p in parts)
        self._listens = any(p._listens for p in parts)
        self.dtype = np.complex64 if scene.iq else np.float32

    def peak_amplitude(self):
        return sum(p.peak_amplitude() for p in self.parts)

    def emit(self, n_cycles, cycle0, rng_attack, observation=None, *, fidelity="beat"):
        a = np.zeros((n_cycles, self.scene.n_chirps, self.scene.n_samples), self.dtype)
        active = np.zeros(n_cycles, dtype=bool)
        for i in range(n_cycles):
            obs = None if observation is None else Observation(observation.emission[i: i + 1], cycle0 + i)
            for p in self.parts:
                a_p, on = p.emit(1, cycle0 + i, rng_attack, obs, fidelity=fidelity)
                if a_p is not None:
                    a[i] += a_p[0]
                active[i] |= bool(on[0])
        return a, active


def scene_attacker(scene: Scene) -> Attacker | None:
    """The scene's attackers as one object (a CompositeAttacker when there are several), or None."""
    parts = [make_attacker(spec.kind, scene, **spec.kwargs()) for spec in scene.attackers]
    if not parts:
        return None
    return parts[0] if len(parts) == 1 else CompositeAttacker(scene, parts)
