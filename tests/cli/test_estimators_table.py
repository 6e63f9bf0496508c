"""`carav estimators`: one row per method of the registry, in its order, each from the method's own file."""
from carav_stream.cli import main as carav
from carav_stream.estimate.estimators import METHODS, REGISTRY


def test_the_table_has_a_row_per_method_in_the_registrys_order_with_its_words(capsys):
    assert carav(["estimators"]) == 0
    rows = capsys.readouterr().out.splitlines()[2:]
    assert [r.split("|")[1].strip().strip("`") for r in rows] == list(METHODS)
    for row, m in zip(rows, REGISTRY.values()):
        assert m.range_words and m.velocity_words and row.endswith(f"| {m.range_words} | {m.velocity_words} |")
