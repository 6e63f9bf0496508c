"""What every attacker model shares: the base classes, the observation an attacker gets, its parameter errors.

``attacker.apply(rx, cycle0, rng_attack, observation, fidelity=...)`` returns ``(rx + a, attack_active)``;
``emit`` returns ``(a, attack_active)`` without ever looking at rx. No attacker is given the activation sequence:
``observation`` is the victim's on-air emission, and the base class hands an attacker row i only *after* it has
produced cycle i (``_listen``). Attackers are stateful (what they have heard); use one object for consecutive
batches, in cycle order.

Two kinds of model:

    Attacker             a plain model: its signal in a cycle depends on the cycle, its parameters, its random
                         draws and what it heard of past cycles, never on the chirps on the air now
    LiveChirpAttacker    answers the victim's chirps as they come (a repeater): its output in chirp k is its
                         reply to the chirps on the air, late by a reaction latency, zero on silent chirps

A live-chirp model is two pure steps, so that a receiver can model its physics without the attacker ever knowing
rho: ``response(fidelity)`` is what it answers to a chirp (independent of rho), and :func:`gate_by_emission` keeps
the answers to the chirps actually on the air. ``emit`` runs both; the pipeline's attacker node sends the response
and its receiver (adc_framer) gates it.

Common parameters: ``start_cycle`` (int, default 0) and ``n_active_cycles`` (int or None = forever). RMS levels
are ``rarms`` = sigma_a / sigma_n, per-sample RMS while on (E|a|^2 = sigma_a^2, for I-only and I/Q alike).

Receiver arrays: where the attacker is, ``azimuth_deg``, is not a model parameter but its place in the scene
(AttackerSpec.azimuth_deg; the attacker block's own parameter). Every model's signal reaches receiver r one way with
the far-field phase of that receiver (radar/arrays.py), applied here once for every model: ``emit`` and ``replies``
give the signal at the receivers. For I-only it turns the analytic signal: a model that renders a waveform from its
physics (``analytic_rendering``, the replicas and the secondary antenna) renders it in complex when ``analytic`` asks
(the scene is I-only and the receivers see it at different phases); of any other model's real samples the base takes
the discrete analytic signal (arrays.hilbert).
"""
from __future__ import annotations

import inspect
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from carav_stream.core.params import Param, problems
from carav_stream.radar.arrays import attack_at_receivers, receiver_phases
from carav_stream.radar.noise import gaussian
from carav_stream.radar.scene import Scene

AZIMUTH = Param("azimuth_deg", float, 0.0, "azimuth of the attacker's antenna from boresight, + towards larger array "
                "positions", unit="deg", low=-90.0, high=90.0)


@dataclass(frozen=True)
class Observation:
    """What an attacker can physically observe of the victim: the on-air emission.

    Attackers must only use row i of ``emission`` when emitting for cycles after cycle0 + i (they
    listen to a cycle, then act on later ones); a LiveChirpAttacker may use the current row, but
    only through a reaction latency (its output in a chirp starts L after that chirp reached it).
    The activation sequence itself is never given to an attacker.
    """

    emission: np.ndarray   # bool (n_cycles, n_chirps), as heard on the air
    cycle0: int


def rarms_param(default: float = 3.0) -> Param:
    """The ``rarms`` parameter the models at a per-sample RMS take, with its meaning and range."""
    return Param("rarms", float, default, "attack RMS over noise RMS, sigma_a / sigma_n, while on", low=0.0)


class AttackerError(ValueError):
    """All problems with an attacker's parameters: ``problems`` is a list of (param, message)."""

    def __init__(self, kind: str, problems: list[tuple[str, str]]):
        self.kind, self.problems = kind, problems
        super().__init__(f"attacker {kind!r}: " + "; ".join(f"{p}: {m}" if p else m for p, m in problems))


class Attacker:
    """Base class of every model, and of the plain ones directly (module docstring).

    A model is one file of this package named after its ``kind``; its class's docstring opens with one line saying
    what it puts on the air (the model listings show it). It declares its own ``params`` (like block parameters)
    and implements ``_batch`` (every cycle of a batch at once) or ``_cycle`` (one cycle)."""

    kind = "none"
    needs_waveform = False       # transmits its own waveform: only the waveform fidelity renders it
    uses_live_emission = False   # answers the current chirp, with a latency (LiveChirpAttacker)
    same_every_chirp = False     # a[c, k, :] is the same for every chirp k (a[:, :1] says it all)
    analytic_rendering = False   # renders its complex (analytic) signal when self.analytic asks (module docstring)
    params: tuple[Param, ...] = ()
    COMMON = (Param("start_cycle", int, 0, "first cycle the attacker is on", unit="cycles", low=0),
              Param("n_active_cycles", int, None, "cycles it stays on (none: until the end)", unit="cycles", low=0,
                    optional=True))

    @classmethod
    def declared(cls) -> tuple[Param, ...]:
        """Every parameter the model takes: the common ones and its own."""
        return cls.COMMON + cls.params

    @classmethod
    def summary(cls) -> str:
        """What the model puts on the air, in one line: the first paragraph of its class docstring."""
        return " ".join(inspect.cleandoc(cls.__doc__ or "").split("\n\n")[0].split())

    def __init__(self, scene: Scene, *, azimuth_deg: float = 0.0, **params):
        self.scene = scene
        self.azimuth_deg = float(azimuth_deg)
        # an I-only scene whose receivers see the signal at different phases: render the analytic signal
        self.analytic = (self.analytic_rendering and not scene.iq
                         and bool(receiver_phases(scene, self.azimuth_deg).any()))
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
        """The attack signal a at the receivers, or None when silent throughout, and attack_active bool
        (n_cycles,). a: (n_cycles, n_chirps, n_samples) of the scene's dtype for one receiver, (n_cycles, n_rx,
        n_chirps, n_samples) for several ((n_cycles, 1, n_chirps, n_samples) when all see it at phase 0, which
        broadcasts): arrays.attack_at_receivers. Draws from rng_attack in cycle order. With ``compact`` a model
        that sends the same samples in every chirp (``same_every_chirp``) returns them once per cycle, a chirp axis
        of 1, which broadcasts over the chirps.

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
        a = np.zeros((n_cycles, rows, self.scene.n_samples), np.complex64 if self.analytic else self.dtype)
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
        return attack_at_receivers(self.scene, a, self.azimuth_deg), active

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
        """Write cycle ``cycle``'s attack into a_c (n_chirps, n_samples; complex64 when ``analytic``); return
        whether it emitted."""
        return False

    def _listen(self, emission_row: np.ndarray) -> None:
        """Hear one past cycle's emission (bool (n_chirps,)), after producing that cycle."""

    def _gauss(self, rng, shape, rms) -> np.ndarray:
        """Gaussian attack samples, E|a|^2 = rms^2 (one block of rng's stream per leading row)."""
        if rng is None:
            raise ValueError(f"attacker {self.kind!r} draws random numbers: pass rng_attack=")
        return gaussian(rng, tuple(shape), rms, self.scene.iq)


class LiveChirpAttacker(Attacker, ABC):
    """Base class of the models that answer the victim's chirps as they are on the air (module docstring).

    A subclass implements ``response``; the base class gates it by the chirps on the air, cycle by cycle."""

    uses_live_emission = True

    @abstractmethod
    def response(self, fidelity: str) -> tuple[np.ndarray, np.ndarray | None]:
        """What it answers in a cycle in which it is on, whatever the victim transmits (rho-independent):
        ``main`` (n_chirps, n_samples), its reply to chirp k heard in chirp k, and ``tail``, its reply to chirp
        k-1 still arriving in chirp k (None when there is none); scene dtype (complex64 when ``analytic``),
        read-only, the same for every cycle, at position 0. :func:`gate_by_emission` keeps the replies to chirps on
        air; ``replies`` gives them at the receivers."""

    def replies(self, fidelity: str) -> tuple[np.ndarray, np.ndarray | None]:
        """``response`` as the receivers get it: (main, tail) of the scene's dtype, (n_chirps, n_samples) for one
        receiver, (n_rx | 1, n_chirps, n_samples) for several (arrays.attack_at_receivers); read-only."""
        main, tail = self.response(fidelity)
        cached = getattr(self, "_replies_of", None)
        if cached is None or cached[0] is not main or cached[1] is not tail:
            turned = tuple(None if x is None else attack_at_receivers(self.scene, x[None], self.azimuth_deg)[0]
                           for x in (main, tail))
            for x in turned:
                if x is not None:
                    x.setflags(write=False)
            self._replies_of, self._replies = (main, tail), turned
        return self._replies

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        main, tail = self.response(fidelity)
        a, active = gate_by_emission(main, tail, np.asarray(live, dtype=bool)[None])
        a_c[...] = a[0]
        return bool(active[0])


def gate_by_emission(main: np.ndarray, tail: np.ndarray | None, on_air: np.ndarray,
                     on: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A repeater's answers kept where the victim's chirps were on the air (a live-chirp attack a_k[m]).

        a[c, k] = live[c, k] main[k] + live[c, k-1] tail[k]     (k >= 1; chirp 0 gets no tail)
        live[c, k] = on_air[c, k] and on[c]

    main: (n_chirps, n_samples), or (1 | n_cycles, n_chirps, n_samples), from a LiveChirpAttacker's ``response``,
    or with a receiver axis (1 | n_cycles, n_rx, n_chirps, n_samples) from its ``replies``; tail: the same shape or
    None (beat fidelity); on_air: bool (n_cycles, n_chirps), chirp k of cycle c was transmitted; on: bool
    (n_cycles,), the repeater is switched on (None = every cycle).
    Returns a, (n_cycles, [n_rx,] n_chirps, n_samples) of main's dtype, and attack_active bool (n_cycles,) = a
    chirp of the cycle was answered. Pure; the same floating-point operations for any batch of cycles.
    """
    if main.ndim == 4:            # every receiver gated alike
        if tail is not None and tail.shape != main.shape:
            raise ValueError(f"tail: expected {main.shape} like main, got {tail.shape}")
        parts = [gate_by_emission(main[:, r], None if tail is None else tail[:, r], on_air, on)
                 for r in range(main.shape[1])]
        return np.stack([a for a, _ in parts], axis=1), parts[0][1]
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
