"""[security] and the tcp edges it protects, checked before anything starts: tcp is authenticated unless the graph
says otherwise in so many words, and keys a run makes for itself stay in its private folder."""
import stat
from pathlib import Path

import pytest
import zmq.auth

from carav_stream.runtime.curve_keys import plan_keys, split_run_problem
from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
TOYS = Path(__file__).resolve().parents[1] / "toy_blocks"


def graph(tmp_path: Path, *, b_address: str = "127.0.0.1", security: str = "") -> Path:
    path = tmp_path / "g.toml"
    path.write_text(f"""\
block_paths = [{str(TOYS)!r}]
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[hosts.a]
address = "127.0.0.1"
port_base = 47000
[hosts.b]
address = "{b_address}"
port_base = 47100
[blocks]
src = {{ type = "counter_source", host = "a" }}
t = {{ type = "tagger", host = "b" }}
log = {{ type = "jsonl_sink", path = "out.jsonl", host = "a" }}
{security}""")
    return path


def problems(path: Path) -> list[str]:
    with pytest.raises(GraphError) as exc:
        load_graph(path)
    return exc.value.problems


def test_the_shipped_two_host_graph_is_valid_and_runs_whole_with_keys_made_for_the_run(tmp_path):
    g = load_graph(GRAPHS / "two_hosts.toml")
    assert not g.warnings
    keys, account = plan_keys(g, None, tmp_path / "keys")
    assert account == {"tcp": "curve", "keys": "run", "warnings": []}
    assert stat.S_IMODE((tmp_path / "keys").stat().st_mode) == 0o700
    for name in ("curve_server_cert", "curve_client_cert"):
        public, secret = zmq.auth.load_certificate(keys[name])
        assert secret and stat.S_IMODE(Path(keys[name]).stat().st_mode) == 0o600
    client = zmq.auth.load_certificate(keys["curve_client_cert"])[0]
    assert set(zmq.auth.load_certificates(keys["curve_authorized"])) == {client}


@pytest.mark.parametrize("address", ["127.0.0.1", "127.0.5.9", "::1", "localhost"])
def test_hosts_that_are_all_this_machine_need_no_keys(tmp_path, address):
    g = load_graph(graph(tmp_path, b_address=address))
    assert not g.warnings and split_run_problem(g, None) is None


@pytest.mark.parametrize("address", ["10.0.0.2", "radar-back.example"])
def test_a_tcp_edge_to_another_machine_without_keys_is_refused_naming_the_edge_and_how_to_make_keys(tmp_path,
                                                                                                    address):
    found = problems(graph(tmp_path, b_address=address))
    assert found == [f"g.toml: connections: edge '{e}' joins host b ({address}), another machine: its tcp edges "
                     "need the graph's CURVE keys; make them with `carav keys DIR` and add the [security] table it "
                     "prints (or write [security] tcp = \"plain\" to send in the clear)"
                     for e in ("src.out -> t.inp", "t.out -> log.inp")]


def test_plain_tcp_is_a_warning_naming_the_edges(tmp_path):
    g = load_graph(graph(tmp_path, b_address="10.0.0.2", security='[security]\ntcp = "plain"\n'))
    assert g.warnings == ["security.tcp = \"plain\": 2 tcp edge(s) ('src.out -> t.inp', 't.out -> log.inp') carry "
                          "frames unauthenticated and in the clear: any process that reaches their ports can send "
                          "into them and read them"]
    keys, account = plan_keys(g, "a", tmp_path / "keys")
    assert keys == {} and account == {"tcp": "plain", "keys": None, "warnings": g.warnings}
    assert not (tmp_path / "keys").exists()


def test_the_graphs_own_keys_serve_a_run_in_parts_and_need_no_run_keys(tmp_path):
    zmq.auth.create_certificates(tmp_path, "server")
    public, _ = zmq.auth.create_certificates(tmp_path, "client")
    (tmp_path / "authorized").mkdir()
    Path(public).rename(tmp_path / "authorized" / "client.key")
    sec = ('[security]\ncurve_server_cert = "server.key_secret"\ncurve_client_cert = "client.key_secret"\n'
           'curve_authorized = "authorized"\n')
    g = load_graph(graph(tmp_path, b_address="10.0.0.2", security=sec))
    assert split_run_problem(g, "a") is None
    keys, account = plan_keys(g, "b", tmp_path / "keys")
    assert keys["curve_server_cert"] == str(tmp_path / "server.key_secret") and account["keys"] == "graph"


def test_a_run_in_parts_without_the_graphs_keys_is_refused(tmp_path):
    g = load_graph(graph(tmp_path))
    assert split_run_problem(g, "b") == (
        "--host b: edge 'src.out -> t.inp' joins a host that another supervisor runs, and keys made for one run "
        "cannot be shared: a graph run in parts needs its own CURVE keys; make them with `carav keys DIR` and add "
        "the [security] table it prints (or write [security] tcp = \"plain\" to send in the clear)")
    with pytest.raises(ValueError, match="--host b: edge"):
        plan_keys(g, "b", tmp_path / "keys")
    assert not (tmp_path / "keys").exists()


@pytest.mark.parametrize("security, expected", [
    ('tcp = "clear"', "g.toml: security.tcp: must be one of ['curve', 'plain'], got 'clear'"),
    ('tcp = "plain"\ncurve_authorized = "."', None),
    ('curve_server_cert = "."', "g.toml: security: CURVE needs all of ['curve_server_cert', 'curve_client_cert', "
                                "'curve_authorized']; missing ['curve_authorized', 'curve_client_cert']"),
    ('keys = "x"', "g.toml: security.keys: unknown key; expected ['curve_server_cert', 'curve_client_cert', "
                   "'curve_authorized', 'tcp']"),
])
def test_a_bad_security_table_is_refused_with_the_key_named(tmp_path, security, expected):
    found = problems(graph(tmp_path, security=f"[security]\n{security}\n"))
    if expected is not None:
        assert expected in found, found
    else:
        assert any("security.tcp: \"plain\" sends the tcp edges in the clear, yet CURVE key files are given" in p
                   for p in found), found


def test_a_graph_with_no_tcp_edge_needs_nothing(tmp_path):
    g = load_graph(GRAPHS / "demo.toml")
    assert plan_keys(g, None, tmp_path / "keys") == ({}, {"tcp": "none", "keys": None, "warnings": []})
    assert not (tmp_path / "keys").exists()
