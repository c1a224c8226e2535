"""Three hidden effects at once, and pairs that include one cause: the bench's sets
(``musclecell bench diagnose --triples``, ``--pairs --including force_offset``).

The rates are the bench's (at least 60 % of triples exact, 80 % of the pairs with a load-cell
offset): one set cannot test them. Seeds below the bench's (10 000).
"""

from pathlib import Path

import pytest

from cell.bench.diagnose import (
    FIRST_SEED,
    PAIRS,
    TRIPLES,
    bench_seeds,
    check_request,
    hidden,
)
from cell.errors import MeasurementError
from cell.synthetic.specimen import write_hidden_effect_set


def test_every_triple_of_the_catalogue_is_there_with_one_viscoelasticity_at_most() -> None:
    assert len(TRIPLES) == 30 and len(set(TRIPLES)) == 30
    assert not any({"viscoelasticity", "nonlinear_viscoelasticity"} <= set(t) for t in TRIPLES)
    assert {hidden(s, "triples") for s in bench_seeds(30, "triples")} == set(TRIPLES)


def test_the_selector_keeps_the_pairs_and_triples_that_hold_the_cause() -> None:
    seeds = bench_seeds(6, "pairs", "force_offset")
    assert seeds[0] == FIRST_SEED["including"] and seeds[0] not in bench_seeds(100, "pairs")
    chosen = {hidden(s, "pairs", "force_offset") for s in seeds}
    assert chosen == {p for p in PAIRS if "force_offset" in p} and len(chosen) == 6
    assert all("plasticity" in hidden(s, "triples", "plasticity")
               for s in bench_seeds(10, "triples", "plasticity"))
    with pytest.raises(MeasurementError, match="including"):
        check_request([1], "single", ("single", "pairs"), "force_offset")
    with pytest.raises(MeasurementError, match="including"):
        check_request([1], "pairs", ("single", "pairs"), "glue")


def test_a_triple_set_hides_all_three(tmp_path: Path) -> None:
    truth = write_hidden_effect_set(tmp_path, 7, ("plasticity", "anisotropy", "force_offset"))
    assert truth.effects == ("anisotropy", "plasticity", "force_offset")
    assert {"ratio_l_t", "yield_strain", "offset_fraction"} <= truth.magnitudes.keys()


@pytest.mark.slow
def test_the_triples_bench_runs_on_one_set() -> None:
    from cell.bench.diagnose import run_diagnose_bench

    report = run_diagnose_bench([9000], workers=1, kind="triples", including="force_offset")
    assert report["including"] == "force_offset" and len(report["sets"]) == 1
    assert "force_offset" in report["sets"][0]["truth"]["effects"]
    assert {"correct", "one_named"} <= report["entries"].keys()
