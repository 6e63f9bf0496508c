"""The live view's line to its own run: the supervisor's status and the attacker swap, through the admin requests
of `carav status` and `carav swap` (runtime.admin), so a swap made from the page is the same swap, validated
and logged the same way, and shows in `carav status` and the run summary; the graph's output ports and the port
taps of the page's scope (admin `ports` and `tap`, runtime/port_tap.py)."""
from __future__ import annotations

import threading
import time
from typing import Any

from carav_stream.radar.attackers import KINDS
from carav_stream.runtime.admin import request
from carav_stream.runtime.protocol import Admin
from carav_stream.runtime.rundir import run_info

STATUS_EVERY_S = 1.0
SWAP_TIMEOUT_S = 40.0
TAP_TIMEOUT_S = 5.0


def models() -> list[str]:
    return list(KINDS)


def swap_params(model: str, rarms: float) -> dict[str, Any]:
    """The attacker block's parameters for a swap from the page: the model, and its RARMS if the model takes one
    (a model that does not take a parameter refuses it by name)."""
    takes = {p.name for p in KINDS[model].declared()}
    return {"model": model, **({"rarms": float(rarms)} if "rarms" in takes else {})}


class RunControl:
    """Status polling (a daemon thread, every STATUS_EVERY_S, into `state.status`) and swaps of `attacker`."""

    def __init__(self, run_id: str, attacker: str, state: Any) -> None:
        self.run_id, self.attacker, self.state = run_id, attacker, state
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._poll, name="live-view-status", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def stop(self) -> None:
        self.stopped.set()

    def _ask(self, kind: str, timeout_s: float, **fields: Any) -> dict[str, Any]:
        return request(run_info(self.run_id), kind, timeout_s, **fields)

    def _poll(self) -> None:
        while not self.stopped.is_set():
            try:
                status, error = self._ask(Admin.STATUS, 5.0), None
                ports = self._ask(Admin.PORTS, 5.0).get("ports") if self.state.ports is None else None
            except (LookupError, TimeoutError, OSError) as exc:
                status, error, ports = None, str(exc), None
            with self.state.lock:
                if status is not None:
                    self.state.status = status
                if isinstance(ports, list):
                    self.state.ports = ports
                self.state.status_error = error
            self.stopped.wait(STATUS_EVERY_S)

    def tap(self, **fields: Any) -> dict[str, Any]:
        """Start, renew or stop a port tap (the admin request `tap`, runtime/port_tap.py); the supervisor's
        answer."""
        return self._ask(Admin.TAP, TAP_TIMEOUT_S, **fields)

    def swap(self, model: str, rarms: float) -> None:
        """Swap the attacker to `model` at `rarms` on a thread of its own (the supervisor answers once the node
        swapped, at a frame boundary); the answer goes to `state.swap_log`."""
        def run() -> None:
            stamp = time.strftime("%H:%M:%S")
            try:
                params = swap_params(model, rarms)
                node = (self.state.status or {}).get("nodes", {}).get(self.attacker, {})
                reply = self._ask(Admin.SWAP, SWAP_TIMEOUT_S, node=self.attacker, block=node.get("block", "attacker"),
                                  params=params)
                text = (f"{stamp} swapped {self.attacker} to {params} from frame seq {reply['next_seq']}"
                        if reply.get("ok") else f"{stamp} swap refused: {reply.get('error')}")
            except (KeyError, LookupError, TimeoutError, OSError, ValueError) as exc:
                text = f"{stamp} swap failed: {exc}"
            with self.state.lock:
                self.state.swap_log.append(text)
        threading.Thread(target=run, name="live-view-swap", daemon=True).start()
