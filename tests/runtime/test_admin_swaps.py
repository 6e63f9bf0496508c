"""The supervisor's answer to a swap when the node cannot take it: every request is answered, none waits for the
deadline or is left without a word when the node's stream ends or the run does."""
from types import SimpleNamespace

import pytest

from carav_graphs import graph_file
from carav_stream.runtime.admin_server import AdminServer
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.node_state import NodeState
from carav_stream.runtime.protocol import Admin, Control, unpack

SWAP = {"type": Admin.SWAP, "node": "attacker", "block": "attacker", "params": {"model": "smart", "rarms": 2.0}}


@pytest.fixture
def server():
    graph = load_graph(graph_file("table1_smart"))
    nodes = {n: NodeState(n, SimpleNamespace(type=node.type)) for n, node in graph.nodes.items()}
    told, answers = [], []
    srv = AdminServer(graph, nodes, SimpleNamespace(t_go=None), send=lambda n, kind, **f: told.append((n, kind)),
                      request_stop=lambda why: None, log=lambda text: None)
    srv.sock = SimpleNamespace(send=lambda raw: answers.append(unpack(raw)),
                               close=lambda linger: answers.append(linger))
    return srv, nodes, told, answers


def test_a_swap_waits_for_a_starting_node_and_is_sent_once_it_is_ready(server):
    srv, nodes, told, answers = server
    srv.on_admin(SWAP)
    srv.deliver_swap()
    assert told == [] and answers == [] and srv.pending is not None      # no answer yet: the node is starting
    nodes["attacker"].ready = True
    srv.deliver_swap()
    srv.deliver_swap()
    assert told == [("attacker", Control.SWAP)] and answers == []


def test_a_swap_still_pending_when_the_run_ends_is_refused_with_the_reason(server):
    srv, nodes, told, answers = server
    srv.on_admin(SWAP)
    srv.run_ended()
    assert len(answers) == 2 and not answers[0]["ok"] and answers[1] > 0   # the answer, time to deliver it
    assert answers[0]["error"] == "the run ended before node 'attacker' took the swap"
    assert srv.pending is None and srv.refused_swaps[0]["error"] == answers[0]["error"]
    srv.run_ended()                                                     # answered once, not twice
    assert len(answers) == 2


@pytest.mark.parametrize("ending, words", [("done", "has ended its stream"), ("failed", "has failed")])
def test_a_node_that_ends_before_it_takes_the_sent_swap_refuses_it_at_once(server, ending, words):
    srv, nodes, told, answers = server
    nodes["attacker"].ready = True
    srv.on_admin(SWAP)
    assert told == [("attacker", Control.SWAP)] and answers == []
    setattr(nodes["attacker"], ending, True)
    srv.deliver_swap()
    assert len(answers) == 1 and not answers[0]["ok"]
    assert answers[0]["error"] == f"node 'attacker' {words} without taking the swap"
    srv.on_admin(SWAP)                                                  # asked again: refused on the spot
    assert len(answers) == 2 and answers[1]["error"] == f"node 'attacker' {words}" and len(told) == 1
