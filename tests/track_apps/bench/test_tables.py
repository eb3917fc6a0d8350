"""The results tables: e1 and e2 beside e_mean, and only trackers marked best."""

from __future__ import annotations

from track_apps.bench.ranking import agent_is_ranked
from track_apps.bench.tables import Row, best_rows, headline, markdown_table, terminal_table


def _row(agent: str, predictor: str, e1: float, e2: float, mota: float) -> Row:
    mean = {"e_mean": (e1 + e2) / 2, "e1": e1, "e2": e2, "mota": mota}
    return Row("BeltSorter-v0", (), agent, predictor, 2, mean, dict.fromkeys(mean, 0.0))


ROWS = [
    _row("detections", "-", 0.0, 1.0, 0.5),  # no tracking: e1 = 0, so e_mean is "lowest"
    _row("gnn", "kf-cv", 0.02, 0.045, 0.9),
    _row("gnn", "kf-ca", 0.01, 0.05, 0.95),
    _row("one-step", "kf-ca", 0.0, 0.0, 1.0),  # reads the truth
]


def test_references_are_never_ranked():
    assert [agent_is_ranked(a) for a in ("detections", "one-step", "gnn", "jpda", "pf")] == [
        False,
        False,
        True,
        True,
        True,
    ]
    assert agent_is_ranked("my-own-agent")  # a record of an agent not registered here


def test_best_marks_go_to_trackers_only():
    assert best_rows(ROWS, "e_mean") == {2}  # 0.03 (kf-ca) against 0.0325; the references' 0.5 and 0
    assert best_rows(ROWS, "e1") == {2}  # detections' and one-step's 0.0 do not count
    assert best_rows(ROWS, "e2") == {1}
    assert best_rows(ROWS, "mota") == {2}


def test_tables_show_e1_and_e2_beside_e_mean_and_star_no_reference():
    assert headline(ROWS)[:4] == ["e_mean", "e1", "e2", "mota"]
    md = markdown_table(ROWS)
    detections_line = next(line for line in md.splitlines() if "| detections |" in line)
    assert "**" not in detections_line
    header = next(line for line in md.splitlines() if line.startswith("| params"))
    assert "| e_mean | e1 | e2 | mota |" in header
    text = terminal_table(ROWS, color=False)
    references = [line for line in text.splitlines() if {"detections", "one-step"} & set(line.split())]
    assert len(references) == 2 and not any("*" in line for line in references)
    assert sum("*" in line for line in text.splitlines() if "kf-ca" in line.split()) == 1  # gnn/kf-ca
