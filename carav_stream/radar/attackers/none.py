"""No attack: the model a graph's attacker node runs by default.

    a_k[m] = 0 in every cycle
"""
from carav_stream.radar.attackers._base import Attacker


class NoAttacker(Attacker):
    """No attack: nothing on the air.

    Never switched on, so every batch is None (no signal to carry between nodes or add at the ADC)."""

    kind = "none"

    def is_on(self, cycle: int) -> bool:
        return False
