"""The okada2020 suite: the ablation of Okada et al. (2020), Table II, on a hard KeypointWalkers-v0 scene."""

from __future__ import annotations

from track_apps.bench.cells import expand, load_suite

HARD = {"num_people": 15, "initial_people": 12, "arrival_rate": 2.0, "camera_pan": 600.0, "num_occluders": 2,
        "vanish_rate": 0.1}  # fmt: skip


def test_the_ablation_suite_holds_every_variant_of_table_2_and_the_baseline_on_ten_seeds():
    cells = expand(load_suite("okada2020"))
    variants = {}
    for cell in cells:
        assert cell.env_id == "KeypointWalkers-v0" and dict(cell.env_kwargs) == HARD and cell.steps is None
        kw = dict(cell.agent_kwargs)
        key = (cell.agent, kw.get("aleatoric"), kw.get("epistemic"), kw.get("window"))
        variants.setdefault(key, set()).add(cell.seed)
        if cell.agent == "pose-smc":
            assert kw["particles"] == 300
    expected = {("pose-baseline", None, None, None)}
    expected |= {("pose-smc", a, e, 10) for a in (True, False) for e in (True, False)}
    expected |= {("pose-smc", True, True, L) for L in (3, 7, 15)}
    assert set(variants) == expected
    assert all(seeds == set(range(10)) for seeds in variants.values())
    assert len({cell.key for cell in cells}) == len(cells) == 80
