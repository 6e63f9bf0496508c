"""What a node takes from its supervisor's control messages, without sockets."""
from carav_stream.runtime.control import ControlState
from carav_stream.runtime.protocol import Control


def test_each_control_message_sets_what_it_names_and_nothing_else():
    ctl = ControlState(go=False)
    ctl.apply({"type": Control.GO})
    assert ctl.go and not ctl.stopping and not ctl.released
    ctl.apply({"type": Control.EOS, "ports": ["a", 3]})
    ctl.apply({"type": Control.CUT, "edges": "not a list"})
    ctl.apply({"type": Control.RECONNECT, "edges": ["x.out -> y.inp"]})
    assert ctl.ended_ports == {"a"} and ctl.cut_edges == set() and ctl.reconnect_edges == {"x.out -> y.inp"}
    ctl.apply({"type": Control.SWAP, "block": "tagger", "params": {}, "id": 1})
    assert ctl.take_swap()["block"] == "tagger" and ctl.pending_swap is None
    ctl.apply({"type": Control.RECOVER})
    ctl.apply({"type": "from a newer supervisor"})
    ctl.apply({"type": Control.STOP})
    ctl.apply({"type": Control.EXIT})
    assert ctl.recovering and ctl.stopping and ctl.released


def test_a_lease_only_grows():
    ctl = ControlState(go=False)
    ctl.apply({"type": Control.LEASE, "upto": 64})
    ctl.apply({"type": Control.LEASE, "upto": 32})          # a late, smaller grant never takes seqs back
    ctl.apply({"type": Control.LEASE, "upto": "lots"})
    assert ctl.seq_lease == 64
