"""Range-gate pull-off: a repeater riding the target puts a false echo on the target's own, then drags it away.

Like ghost it sends, in every chirp period, a replica of the victim's chirp (it knows the victim's timing and slope,
not rho), here delayed as the echo of a point that first sits on the target (the capture: the victim's tracker
takes the stronger false echo for the car) and then walks away from it (the drag: the track follows the false echo
if the walk is gentle enough for its gate):

    capture   cycles start_cycle .. start_cycle + capture_cycles - 1:   R = range_m
    drag      t = (cycle - start_cycle - capture_cycles) t_cycle from the drag's first cycle on
              v(t) = min(pull_accel_mps2 t, pull_mps)                   the drag's speed, built up at pull_accel_mps2
              R(t) = range_m + integral_0^t v                            a t^2 / 2, then pull_mps (t - t1 / 2) from
                                                                         t1 = pull_mps / pull_accel_mps2 on
    tau0 = 2 R / c,   alpha = 2 (rdot + [v(t) if doppler]) / c,   rdot = velocity_mps - v_radar,   RMS rarms sigma_n

With `doppler` the false echo's Doppler follows its walk (range and range rate agree, as a real target's would);
without, it keeps the target's Doppler and only its range walks (the classic range-only pull-off, which a tracker
that measures range rate sees as inconsistent). range_m and velocity_mps default to the scene's first target, the
car the repeater rides on; the false range stops at 0 m.
"""
import math

from carav_stream.core.params import Param
from carav_stream.core.units import C_MPS
from carav_stream.radar.attackers._base import rarms_param
from carav_stream.radar.attackers._replica import ReplicaAttacker


class PullOffAttacker(ReplicaAttacker):
    """Range-gate pull-off: a chirp-synchronised replica (timing and slope known, not rho) first on the target at
    `range_m` (ground speed `velocity_mps`; default the scene's first target) for `capture_cycles`, then dragged away
    at up to `pull_mps`, reached at `pull_accel_mps2`, its Doppler following the walk with `doppler`; RMS `rarms`."""

    kind = "pull_off"
    params = (Param("range_m", float, None, "range where it captures (none: the scene's first target)", unit="m",
                    low=0.0, strict=True, optional=True),
              Param("velocity_mps", float, None, "ground speed where it captures, target convention (none: the "
                    "scene's first target's)", unit="m/s", optional=True),
              Param("capture_cycles", int, 200, "cycles it sits on the target before the drag", unit="cycles",
                    low=0),
              Param("pull_mps", float, 4.0, "speed of the drag once built up: the false range's rate away from "
                    "the target (negative: towards the radar)", unit="m/s"),
              Param("pull_accel_mps2", float, 8.0, "how fast the drag builds its speed up", unit="m/s^2", low=0.0,
                    strict=True),
              Param("doppler", bool, True, "the false echo's Doppler follows its walk (else the target's)"),
              rarms_param())

    def __init__(self, scene, **params):
        super().__init__(scene, **params)
        target = scene.targets[0] if scene.targets else None
        self.range_m = target.range_m if self.range_m is None else self.range_m
        self.velocity_mps = target.velocity_mps if self.velocity_mps is None else self.velocity_mps

    def _validate(self):
        if not self.scene.targets and (self.range_m is None or self.velocity_mps is None):
            missing = [p for p in ("range_m", "velocity_mps") if getattr(self, p) is None]
            return [(p, "the scene has no target to ride on: give it") for p in missing]
        return []

    def offset(self, cycle: int) -> tuple[float, float]:
        """(range offset [m], speed of the drag [m/s]) of the false echo from the target's, at cycle's start."""
        t = (cycle - self.start_cycle - self.capture_cycles) * self.scene.t_cycle_s
        if t <= 0:
            return 0.0, 0.0
        a, v_max = self.pull_accel_mps2, abs(self.pull_mps)
        t1 = v_max / a
        walk = a * t * t / 2 if t < t1 else v_max * (t - t1 / 2)
        return math.copysign(walk, self.pull_mps), math.copysign(min(a * t, v_max), self.pull_mps)

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        walk, speed = self.offset(cycle)
        rdot = self.velocity_mps - self.scene.radar_speed_mps + (speed if self.doppler else 0.0)
        main, tail = self._replica(2.0 * max(self.range_m + walk, 0.0) / C_MPS, 2.0 * rdot / C_MPS, None, fidelity)
        a_c += main
        if tail is not None:         # it transmits in every chirp period, so every tail is there
            a_c += tail
        return True
