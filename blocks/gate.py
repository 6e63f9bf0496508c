"""Gate: pass a cycle to target processing only on a clean verdict (Algorithm 1, steps 5-6). Fail closed.

    pass(cycle)  <=>  a verdict for the same cycle exists  and  C(eta) < 1  and  the frame was valid

A frame carries several cycles: the clean ones go on together, the others each get an alarm record. Frames of
several receivers (a receiver axis after the cycles, the chirps after it) go through the same way.

Ports   in  frames    ADC frames of the cycles (int16 codes or float32 | complex64 samples), one receiver's
                      (cycles, chirps, ...) or a receiver array's (cycles, n_rx, chirps, ...)
        in  verdict   rms_detector's verdicts for the same seq (payload: rho)
        out clean     the clean cycles' frames plus their rho (array "rho"), header verdict = "clean",
                      per_cycle cycle_index, q and the frame's own per-cycle fields
        out alarms    header only: per_cycle cycle_index and reason "attack" | "invalid" | "no_rho" |
                      "no_verdict" | "no_frame" | "bad_verdict" for every refused cycle
Both outputs carry on the verdict's attacker columns where it has them (a receiver array's: ATTACKER_FIELDS).
A frame whose verdict never comes (detector down), or whose verdict does not say "alarm: false" and
"invalid: false" for a cycle in so many words, is refused for that cycle, never passed.
Graph   gate = { type = "gate" }
"""
import numpy as np

from carav_stream.runtime import Block, Frame, In, Out, n_cycles, pick

ATTACKER_FIELDS = ("attack_azimuth_deg", "attack_azimuth_std_deg", "attack_reason")   # rms_detector's, on arrays


def _chirp_counts(data) -> tuple[int, ...]:
    """The chirps per cycle the frames may hold: axis 1 of one receiver's (cycles, chirps, samples[, 2]), axis 2 of
    a receiver array's (cycles, n_rx, chirps, samples[, 2]); 4-D int16 codes may be either (I/Q of one receiver,
    I-only of an array: the gate does not know the scene)."""
    if data.ndim == 3:
        return (data.shape[1],)
    if data.ndim == 4 and data.dtype == np.int16:
        return (data.shape[1], data.shape[2])
    return (data.shape[2],)


def _column(per: object, name: str, n: int) -> list | None:
    values = per.get(name) if isinstance(per, dict) else None
    return values if isinstance(values, list) and len(values) == n else None


def _reason(alarm: object, invalid: object, raised_by: object) -> str | None:
    """None for a clean verdict (both flags False, in so many words), else why the cycle is refused."""
    if alarm is False and invalid is False:
        return None
    if invalid is True:
        return "no_rho" if raised_by == "no_rho" else "invalid"
    return "attack" if alarm is True else "bad_verdict"


class Gate(Block):
    inputs = (In("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64")),
              In("verdict", kind="verdict", dtypes=("bool",)))
    outputs = (Out("clean", kind="clean_frame", dtypes=("int16", "float32", "complex64")),
               Out("alarms", kind="alarm", dtypes=("none",)))

    def process(self, frames: Frame, verdict: Frame) -> dict[str, Frame]:
        n = n_cycles(frames)
        data, rho, per = frames.payload, verdict.payload, verdict.header.get("per_cycle")
        alarm, invalid = _column(per, "alarm", n), _column(per, "invalid", n)
        try:
            pick(frames, [])   # the frame's own per-cycle fields are well formed
            usable = (alarm is not None and invalid is not None and n_cycles(verdict) == n and data is not None
                      and rho is not None and data.ndim >= 3 and rho.ndim == 2 and rho.shape[0] == data.shape[0] == n
                      and rho.shape[1] in _chirp_counts(data))
        except ValueError:
            usable = False
        if not usable:
            return {"alarms": self._refuse(frames, range(n), ["bad_verdict"] * n)}
        raised_by, q = _column(per, "raised_by", n) or [None] * n, _column(per, "q", n) or [None] * n
        attacker = {k: v for k in ATTACKER_FIELDS if (v := _column(per, k, n)) is not None}
        reasons = [_reason(a, i, r) for a, i, r in zip(alarm, invalid, raised_by)]
        keep = [i for i in range(n) if reasons[i] is None]
        refused = [i for i in range(n) if reasons[i] is not None]
        out: dict[str, Frame] = {}
        if keep:
            whole = not refused   # every cycle clean: the frame goes on as it came
            if not whole:         # the clean cycles gathered straight into the output (its shared-memory slot)
                slot = self.output_buffer("clean", (len(keep),) + data.shape[1:], data.dtype)
                data = np.take(data, keep, axis=0, out=slot, mode="clip")   # "raise" would copy twice
            out["clean"] = frames.derive(data, arrays={"rho": rho if whole else rho[keep]},
                                         verdict="clean", eta=verdict.header.get("eta"), cycles=len(keep),
                                         per_cycle=pick(frames, keep, q=[q[i] for i in keep],
                                                        **{k: [v[i] for i in keep] for k, v in attacker.items()}))
        if refused:
            out["alarms"] = self._refuse(frames, refused, [reasons[i] for i in refused],
                                         q=[q[i] for i in refused], raised_by=[raised_by[i] for i in refused],
                                         **{k: [v[i] for i in refused] for k, v in attacker.items()})
        return out

    @staticmethod
    def _refuse(frame: Frame, rows, reasons: list, **extra: list) -> Frame:
        rows = list(rows)
        try:
            per = pick(frame, rows, reason=reasons, **extra)
        except ValueError:   # malformed per-cycle fields: the cycles are still refused, one by one
            per = {"cycle_index": list(range(frame.cycle, frame.cycle + len(rows))), "reason": reasons, **extra}
        return frame.derive(None, cycles=len(rows), alarm=True, per_cycle=per)

    def unpaired(self, port: str, frame: Frame) -> dict[str, Frame]:
        n = n_cycles(frame)
        return {"alarms": self._refuse(frame, range(n), ["no_verdict" if port == "frames" else "no_frame"] * n)}
