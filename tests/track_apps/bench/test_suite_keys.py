"""The shipped suites are TOML files whose cells are those of the Python definitions they replaced.

The keys below were computed from the Python suites (``SUITES`` of the bench's ``cells.py``) before
they became ``track_apps/bench/suites/{quick,full,sorting}.toml``: the quick suite key by key
and in order (``make demo`` runs it; its record files keep their names), the full and sorting
suites as a digest of their ordered keys.
"""

from __future__ import annotations

import hashlib

import pytest

from track_apps.bench.cells import expand, load_suite

#: ``[c.key for c in expand(SUITES["quick"])]`` of the Python definition, in order.
QUICK_KEYS = (
    "3d655b1fd0a92fee",
    "683d9fb6330c1fd9",
    "d4542c1f5c3fe0b2",
    "8c719cd97be3c44d",
    "1ae65a117d79e3d0",
    "25a70033f8fc0192",
    "2a5227d42a24fb8b",
    "8d092c453285a0ff",
    "77badf98d7924bdc",
    "ec556c1ba776697e",
    "68981cf9908d62ae",
    "1a6151dbd4e72986",
    "a546ff68f3cf2a18",
    "d5128409db348a0f",
    "3403eb282b8f67de",
    "674ff884dff32cd2",
    "9485eb097d03a5e1",
    "d6962320cad449e0",
    "fa05d9546f49c432",
    "2026020b76aab0a7",
    "41048f4dbba1fa53",
    "ad5469c62d1ec656",
    "edb9453b10678ac0",
    "9ddee89538664f00",
    "cf2768e24adb8037",
    "abfec14e20cd5312",
    "596c18170176b317",
    "dea664398095a790",
    "9db19f28110fd3e2",
    "3db9bfe29fc3be40",
    "a3387587575c5b86",
    "1aae4923073bc773",
    "e03ff0a9fd04cbd0",
    "58bd8afc399abbdc",
    "d9419207ee623b32",
    "b4b4ba21dcbc8e64",
    "4dc8b3bae5b91f52",
    "6c7dbaa08bccc895",
    "aa47e1b28b88011b",
    "15fed393f126959c",
    "79d1897c3ee19609",
    "148267387dccddc5",
    "7049ad2cdf09e77a",
    "0a8878bc14115e2d",
    "9a624de396fe5ed6",
    "3d036452a02e1cfd",
    "f7bd052341929027",
    "be109b8620981944",
    "a05616b9b9fe8d26",
    "72231080e4cf29d3",
    "97d6d57a3c435c2e",
    "421d098fb1e1d766",
)

#: The cells the jpda tracker added to the quick suite (every Gaussian predictor where gnn runs), in order.
QUICK_JPDA_KEYS = (
    "dddcf5095fd28424",
    "067c9d9ac43516f2",
    "a53507e6cdac4e2a",
    "5b3723ca93c25247",
    "02dc6b83ee32fc65",
    "5bdaabc22493ff59",
    "48f1a1da8b3fa44c",
    "4a39d0001cd8faa4",
    "35926f4dda6eca10",
    "d3dc7d91743731e6",
    "8b0444950393a500",
    "bac13da6aae5f6e3",
    "9114d09a66178a84",
    "c78f8699880b9b2e",
    "bbea818307ab0017",
    "be2f527baad40d25",
    "b8386752b80f941b",
    "b2d1f877eac16dd9",
    "0fac7edf8cba984e",
    "3d95350a883faac6",
    "5aa1d43eb153ac40",
    "2c64519f745b6b69",
    "d429b62b2db54297",
    "fae9b6312f7c7ac2",
    "6418c117f9482aaf",
    "bc1098529400628b",
    "a52f80302d6c16c6",
    "d3a574ccecd03438",
    "68c8b9edbd4075fd",
    "83cde6f8400ae3a5",
    "ae99894649d44ef6",
    "928a7e9511a9e8f4",
    "9511b0ac2cbc3a73",
    "7fd6be6f70f4403b",
    "2d6f43524f9fbc60",
    "7e5126b3275b8c4c",
)

#: sha256 of the comma-joined ordered keys of the Python definitions, and their count.
DIGESTS = {
    "full": (610, "a94322b991b467b42ad666d538fde509c02582abdf3b40ab203e9fd5d23d9bb1"),
    "sorting": (180, "5fd23384a1fcb8bdd50e2c21667ac7545807b7a6aa5cd1839d5eccaeb851a198"),
}


def _split(cells: list) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Keys of the cells of the agents the Python definitions knew, and of jpda's, each in order."""
    return (
        tuple(c.key for c in cells if c.agent != "jpda"),
        tuple(c.key for c in cells if c.agent == "jpda"),
    )


def test_the_quick_suite_expands_to_exactly_the_cells_of_its_python_definition():
    """The agents of the Python definition keep their cells; a registered agent adds its own."""
    assert _split(expand(load_suite("quick"))) == (QUICK_KEYS, QUICK_JPDA_KEYS)


def test_the_quick_suite_is_its_own_quick_variant():
    assert _split(expand(load_suite("quick", quick=True))) == (QUICK_KEYS, QUICK_JPDA_KEYS)


@pytest.mark.parametrize("name", sorted(DIGESTS))
def test_the_full_and_sorting_suites_expand_to_the_cells_of_their_python_definitions(name):
    keys = _split(expand(load_suite(name)))[0]
    assert (len(keys), hashlib.sha256(",".join(keys).encode()).hexdigest()) == DIGESTS[name]


@pytest.mark.parametrize("name", ["full", "sorting"])
def test_every_main_suite_has_a_smaller_quick_variant(name):
    full, quick = expand(load_suite(name)), expand(load_suite(name, quick=True))
    assert 0 < len(quick) < len(full)
    assert all(c.steps is not None and c.steps <= 100 for c in quick)
