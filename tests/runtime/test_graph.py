from pathlib import Path

import pytest

from carav_stream.cli import main as carav
from carav_stream.runtime.block import Block, BlockError, In, Out, Param
from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.validate import swap_problems

TOYS = Path(__file__).resolve().parents[1] / "toy_blocks"


def write(tmp_path: Path, body: str, name: str = "g.toml") -> Path:
    path = tmp_path / name
    path.write_text(f'block_paths = ["{TOYS}"]\n' + body)
    return path


GOOD = """
connections = ["src.out -> t.inp", "t.out -> add.a", "src.out -> add.b", "add.out -> log.inp"]
[blocks]
src = { type = "counter_source" }
t = { type = "tagger", offset = 1 }
add = { type = "adder" }
log = { type = "jsonl_sink", path = "x.jsonl" }
"""


def problems_of(path: Path, overrides=()) -> list[str]:
    with pytest.raises(GraphError) as info:
        load_graph(path, list(overrides))
    return info.value.problems


def test_good_graph_loads_with_int_widened_to_float(tmp_path):
    g = load_graph(write(tmp_path, GOOD))
    assert sorted(g.nodes) == ["add", "log", "src", "t"]
    assert g.nodes["t"].params["offset"] == 1
    assert g.sources() == ["src"]
    assert g.topological_order().index("src") < g.topological_order().index("log")


def test_every_problem_is_reported_at_once_each_located(tmp_path):
    path = write(tmp_path, """
connections = ["src.out -> t.inp", "t.nope -> log.inp", "ghost.out -> add.a", "src.out -> add.a", "garbage"]
[blocks]
src = { type = "counter_source", n_values = 0 }
t = { type = "tagger", offset = "big", colour = "red" }
add = { type = "adder" }
log = { type = "jsonl_sink" }
x = { type = "no_such_block" }
""")
    found = "\n".join(problems_of(path))
    for expected in [
        "g.toml: blocks.src.n_values: must be >= 1, got 0",
        "g.toml: blocks.t.offset: must be float, got str 'big'",
        "g.toml: blocks.t.colour: unknown parameter",
        "g.toml: blocks.log.path: missing required parameter",
        "g.toml: blocks.x.type: unknown block type 'no_such_block'",
        "connections[1] 't.nope -> log.inp': t (tagger) has no output port 'nope'",
        "connections[2] 'ghost.out -> add.a': unknown node 'ghost'",
        "connections[4] 'garbage': expected 'node.port -> node.port'",
        "input add.b (adder) is not connected",
    ]:
        assert expected in found, f"missing: {expected}\nin:\n{found}"


def test_doubly_connected_input_is_refused(tmp_path):
    path = write(tmp_path, """
connections = ["a.out -> add.a", "b.out -> add.a", "b.out -> add.b"]
[blocks]
a = { type = "counter_source" }
b = { type = "counter_source" }
add = { type = "adder" }
""")
    assert any("input add.a is connected twice" in p for p in problems_of(path))


def test_cycles_are_refused_naming_their_blocks(tmp_path):
    path = write(tmp_path, """
connections = ["src.out -> add.a", "add.out -> t.inp", "t.out -> add.b"]
[blocks]
src = { type = "counter_source" }
add = { type = "adder" }
t = { type = "tagger" }
""")
    assert any("cycle: add -> t -> add" in p for p in problems_of(path))


def test_incompatible_port_kinds_and_dtypes_are_refused(tmp_path):
    path = write(tmp_path, """
connections = ["src.out -> sink.inp"]
[blocks]
src = { type = "counter_source" }
sink = { type = "numbers_only" }
""")
    assert any("port kinds differ: out carries 'numbers', inp expects 'counts'" in p for p in problems_of(path))


def test_malformed_toml_names_the_file_and_line(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[blocks]\nsrc = { type = \n")
    (problem,) = problems_of(path)
    assert problem.startswith("broken.toml: not valid TOML") and "line 2" in problem


def test_graph_wide_parameters_reach_blocks_that_declare_them_and_unknown_ones_are_refused(tmp_path):
    g = load_graph(write(tmp_path, 'tag = "wide"\n' + GOOD))
    assert g.nodes["t"].params["tag"] == "wide"
    assert any("colour: no block of this graph takes" in p for p in problems_of(write(tmp_path, 'colour = 1\n' + GOOD)))


def test_set_overrides_are_validated_like_the_file(tmp_path):
    path = write(tmp_path, GOOD)
    assert load_graph(path, ["t.offset=2.5"]).nodes["t"].params["offset"] == 2.5
    found = problems_of(path, ["t.offset=abc", "nobody.x=1", "bad"])
    assert any("blocks.t.offset: must be float, got str 'abc'" in p for p in found)
    assert any("unknown node 'nobody'" in p for p in found)
    assert any("expected node.param=value" in p for p in found)


def test_restart_policy_and_hosts_are_checked(tmp_path):
    path = write(tmp_path, GOOD.replace('type = "adder" }', 'type = "adder", restart = "sometimes", host = "mars" }'))
    found = "\n".join(problems_of(path))
    assert "blocks.add.restart.policy: must be one of ['never', 'on-failure'], got 'sometimes'" in found
    assert "blocks.add.host: unknown host 'mars'" in found


def test_swap_checks_port_compatibility(tmp_path):
    g = load_graph(write(tmp_path, GOOD))
    assert swap_problems(g, "t", "tagger_b", {"factor": 3.0}) == []
    assert any("has no input 'inp'" in p for p in swap_problems(g, "t", "adder", {}))
    assert any("unknown parameter" in p for p in swap_problems(g, "t", "tagger_b", {"gain": 1}))
    assert any("unknown node" in p for p in swap_problems(g, "zz", "tagger_b", {}))


def test_validate_command_exit_status(tmp_path, capsys):
    assert carav(["validate", str(write(tmp_path, GOOD))]) == 0
    assert carav(["validate", str(write(tmp_path, GOOD.replace("adder", "nothing"), "bad.toml"))]) == 3
    assert "bad.toml: blocks.add.type: unknown block type 'nothing'" in capsys.readouterr().err


def test_params_are_typed_and_bounded():
    class B(Block):
        inputs = (In("x"),)
        outputs = (Out("y"),)
        params = (Param("eta", float, 1.5, low=0.0, strict=True), Param("mode", str, "a", choices=("a", "b")),
                  Param("n", int, 1))

    assert B(eta=2).eta == 2.0
    with pytest.raises(BlockError, match="eta: must be > 0, got -1.5"):
        B(eta=-1.5)
    with pytest.raises(BlockError, match=r"mode: must be one of \['a', 'b'\], got 'c'"):
        B(mode="c")
    with pytest.raises(BlockError, match="n: must be int, got bool True"):
        B(n=True)


def test_a_value_error_from_check_params_becomes_a_block_error_naming_it():
    class NeedsFile(Block):
        params = (Param("path", str, "x"),)

        def check_params(self):
            raise ValueError(f"{self.path}: no such scene file")

    with pytest.raises(BlockError, match="x: no such scene file"):
        NeedsFile()


READER = '''
from pathlib import Path
from carav_stream.runtime.block import Block, BlockError, In, Param


class TableReader(Block):
    inputs = (In("inp", kind="numbers", dtypes=("float64",)),)
    params = (Param("table", str, "builtin", "builtin, or a file this block reads", file=True),)

    def check_params(self):
        if self.table != "builtin" and not Path(self.table).is_file():
            raise BlockError(f"table file {self.table!r} not found")

    def process(self, inp):
        return None
'''


def reader_graph(folder: Path, table_line: str, node_table: str = "") -> Path:
    (folder / "my_blocks").mkdir(parents=True)
    (folder / "my_blocks" / "table_reader.py").write_text(READER)
    extra = f", table = {node_table!r}" if node_table else ""
    path = folder / "g.toml"
    path.write_text(f'block_paths = ["{TOYS}", "my_blocks"]\n{table_line}\nconnections = ["src.out -> r.inp"]\n'
                    f'[blocks]\nsrc = {{ type = "counter_source" }}\nr = {{ type = "table_reader"{extra} }}\n')
    return path


def test_a_file_parameter_written_in_a_graph_is_relative_to_the_graph_folder(tmp_path, monkeypatch):
    folder, elsewhere = tmp_path / "project", tmp_path / "elsewhere"
    elsewhere.mkdir()
    path = reader_graph(folder, "", node_table="tables/t.csv")
    (folder / "tables").mkdir()
    (folder / "tables" / "t.csv").write_text("1,2\n")
    monkeypatch.chdir(elsewhere)
    g = load_graph(path)
    assert g.nodes["r"].params["table"] == str((folder / "tables" / "t.csv").resolve())
    # a --set value is the user's, relative to the working directory: not found from here, and located
    assert any("blocks.r" in p and "'tables/t.csv' not found" in p
               for p in problems_of(path, ["r.table=tables/t.csv"]))
    (elsewhere / "mine.csv").write_text("3\n")
    assert load_graph(path, ["r.table=mine.csv"]).nodes["r"].params["table"] == "mine.csv"


def test_a_graph_wide_file_parameter_is_resolved_and_other_values_are_left_as_written(tmp_path, monkeypatch):
    folder = tmp_path / "project"
    path = reader_graph(folder, 'table = "t.csv"')
    (folder / "t.csv").write_text("1\n")
    monkeypatch.chdir(tmp_path)
    g = load_graph(path)
    assert g.nodes["r"].params["table"] == str((folder / "t.csv").resolve())
    assert g.params["table"] == str((folder / "t.csv").resolve())     # a swapped-in block gets it too
    (folder / "t.csv").unlink()
    assert any("'t.csv' not found" in p for p in problems_of(path))            # not there: left as written
    path.write_text(path.read_text().replace('table = "t.csv"', 'table = "builtin"'))
    assert load_graph(path).nodes["r"].params["table"] == "builtin"             # a name, not a file


def test_radar_blocks_read_their_scene_file_relative_to_the_graph():
    from carav_stream.runtime.registry import Registry
    registry = Registry([])
    with_scene = [b for b in registry.names() if any(p.name == "scene" for p in registry.get(b).cls.params)]
    assert len(with_scene) >= 7
    assert all(p.file for b in with_scene for p in registry.get(b).cls.params if p.name == "scene")
