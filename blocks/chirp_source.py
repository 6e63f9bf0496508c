"""Chirp source: a new activation sequence every cycle and the chirps it transmits (Algorithm 1, steps 1-2).

    rho(k) in {0, 1},  sum_k rho(k) = N_r / 2,  fresh every cycle; chirp k is transmitted iff rho(k) = 1

With TDM (a scene whose transmitters fire in turn, n_slots chirps a loop) rho is drawn per loop: constant within
each loop, half the loops active, so an active loop fires every transmitter (radar/activation.py).

A frame carries `batch` consecutive cycles (header cycle = the first, cycles = how many; the last frame of a
run is sized to the cycles asked for): the kernels downstream are vectorised over cycles, and one frame per
batch spreads the per-frame cost of every hop over many cycles. Every cycle keeps its own fresh sequence: from
the OS's secure generator without a seed (activation "auto" picks "secure" then, "seeded" with a seed). Paced
(`cycles_per_s`), frames leave no faster than that rate and never catch up after a stall; the radar's own rate is
1 / t_cycle_s (`carav scenes`).

Ports   out tx    bool (cycles, n_chirps)   the transmitted chirps: what goes on the air, to the channel
        out rho   bool (cycles, n_chirps)   the activation sequences: a private edge to the detector alone
Graph   source = { type = "chirp_source", batch = 16 }
"""
import time

from carav_stream.radar.scene import aliased_targets, velocity_warning
from carav_stream.radar.streams import SCENE, SEED, scene_of, seed_streams
from carav_stream.runtime import Block, Frame, Out, Param


class ChirpSource(Block):
    outputs = (Out("tx", kind="tx", dtypes=("bool",), doc="transmitted chirps of the cycles", private=True),
               Out("rho", kind="rho", dtypes=("bool",), doc="activation sequences (private: detector only)",
                   private=True))
    params = (SCENE, SEED,
              Param("activation", str, "auto", "activation source", choices=("auto", "secure", "seeded", "lfsr")),
              Param("batch", int, 16, "cycles per frame", low=1, high=4096),
              Param("cycles_per_s", float, 0.0, "at most this many cycles a second (0: unpaced)", unit="1/s",
                    low=0.0))

    def check_params(self) -> None:
        self.n_chirps, self.n_slots = scene_of(self.scene).n_chirps, scene_of(self.scene).n_slots
        seed_streams(self.seed, self.activation)

    def param_warnings(self) -> list[str]:
        """The scene's doubtful physics, but a velocity beyond the unambiguous interval: that matters to the range
        estimator alone, which warns when it does not unalias it (its max_speed_mps)."""
        scene = scene_of(self.scene)
        aliased = {velocity_warning(scene, i) for i in aliased_targets(scene)}
        return [w for w in scene.warnings if w not in aliased]

    def start(self) -> None:
        self.streams = seed_streams(self.seed, self.activation, self.instance)
        self.release_at: float | None = None

    def ready_in(self, seq: int) -> float:
        if not self.cycles_per_s:
            return 0.0
        now = time.monotonic()
        if self.release_at is None or self.release_at < now:   # the first frame, or after a stall: now
            self.release_at = now
        return self.release_at - now

    def generate(self, seq: int) -> dict[str, Frame]:
        n = min(self.batch, self.cycle_budget or self.batch)
        rho = self.streams.activation.next(n, self.n_chirps, self.n_slots)
        if self.cycles_per_s:
            self.release_at += n / self.cycles_per_s
        cycles = {"cycle": seq * self.batch, "cycles": n}   # only a run's last frame is short
        return {"tx": Frame.of(rho, **cycles), "rho": Frame.of(rho.copy(), **cycles)}
