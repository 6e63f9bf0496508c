"""Gate: pass a cycle to target processing only on a clean verdict (Algorithm 1, steps 5-6). Fail closed.

    pass(cycle)  <=>  a verdict for the same seq exists  and  C(eta) < 1  and  the frame was valid

Ports   in  frames    float32 | complex64 (n_chirps, n_samples)   ADC frame of one cycle
        in  verdict   rms_detector's verdict for the same seq (payload: rho)
        out clean     the frame plus its rho (array "rho"), header verdict = "clean", q
        out alarms    header only: one record per refused cycle, reason "attack" | "invalid" | "no_rho"
                      | "no_verdict" | "no_frame"
A frame whose verdict never comes (detector down) is refused as "no_verdict", never passed.
Graph   gate = { type = "gate" }
"""
from carav_stream.block import Block, In, Out
from carav_stream.frames import Frame


class Gate(Block):
    inputs = (In("frames", kind="adc_frame", dtypes=("float32", "complex64")),
              In("verdict", kind="verdict", dtypes=("bool",)))
    outputs = (Out("clean", kind="clean_frame", dtypes=("float32", "complex64")),
               Out("alarms", kind="alarm", dtypes=("none",)))

    def process(self, frames: Frame, verdict: Frame) -> dict[str, Frame]:
        v = verdict.header
        if v.get("alarm") is not False or v.get("invalid") is not False:
            reason = v.get("reason") or ("invalid" if v.get("invalid") else "attack")
            return {"alarms": verdict.derive(None, reason=reason)}
        return {"clean": frames.derive(frames.payload, arrays={"rho": verdict.payload}, verdict="clean",
                                       q=v.get("q"), eta=v.get("eta"))}

    def unpaired(self, port: str, frame: Frame) -> dict[str, Frame]:
        reason = "no_verdict" if port == "frames" else "no_frame"
        return {"alarms": frame.derive(None, reason=reason, alarm=True)}
