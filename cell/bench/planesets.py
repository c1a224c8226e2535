"""The orthotropy bench: the specimen diagnosis on synthetic shear and mixed sets that hide
orthotropy or nothing (:mod:`cell.synthetic.planesets`), on seeds the tests never use.

A hidden set is exact when the diagnosis names what it hides and nothing else (``orthotropy``;
with ``turned``, ``fibre_direction`` too), and its ratio is within 15 % when the fitted
E_s / E_n is within a factor 1.15 of the truth; an unchanged set is right when nothing is
named. Targets (issue 51): >= 95 % exact, ratios within 15 %, fibre turns within 10 degrees,
nothing named on >= 9 of 10 unchanged sets.

Usage::

    rows = orthotropy_bench(range(2000, 2010))
    summary(rows)["exact"]
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from cell.diagnosis.engine.settings import DiagnosisParams
from cell.diagnosis.sets import diagnose_set
from cell.measure.specimens import load_measurement_set
from cell.synthetic.planesets import PLANE_KINDS, write_plane_set

#: The fitted ratio's largest factor from the truth that counts as within 15 %.
RATIO_TOLERANCE = 1.15


def orthotropy_bench(seeds: Iterable[int], kinds: Iterable[str] = PLANE_KINDS,
                     workers: int = 1, turned: bool = False) -> list[dict[str, Any]]:
    """Diagnose, for each seed and kind, the set that hides orthotropy (its fibres ``turned``
    as well) and the unchanged one: one row each (kind, seed, hidden, truth and fitted ratio
    and turn, the causes hidden and named, seconds)."""
    rows = []
    for kind in kinds:
        for seed in seeds:
            for hidden in (True, False):
                with tempfile.TemporaryDirectory() as folder:
                    truth = write_plane_set(Path(folder), seed, kind, hidden, turned and hidden)
                    start = time.perf_counter()
                    result = diagnose_set(load_measurement_set(folder),
                                          DiagnosisParams(workers=workers)).uniaxial
                    seconds = time.perf_counter() - start
                rows.append({"kind": kind, "seed": seed, "hidden": hidden,
                             "truth": truth.sheet_over_normal, "causes": list(result.causes),
                             "fitted": result.extended.params.get("sheet_over_normal"),
                             "hidden_causes": list(truth.causes), "turn": truth.fibre_turn_deg,
                             "fitted_turn": result.extended.params.get("fibre_turn_deg"),
                             "seconds": seconds})
    return rows


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The bench's figures: exact share, ratio and turn errors of the hidden sets, the
    unchanged sets named nothing, the median seconds."""
    hidden = [r for r in rows if r["hidden"]]
    plain = [r for r in rows if not r["hidden"]]
    exact = [r for r in hidden if r["causes"] == r["hidden_causes"]]
    errors = [abs(math.log(r["fitted"] / r["truth"])) for r in exact]
    turns = [abs(r["fitted_turn"] - r["turn"]) for r in exact if r["turn"]]
    seconds = sorted(r["seconds"] for r in rows)
    return {"hidden_sets": len(hidden), "exact": len(exact) / max(len(hidden), 1),
            "ratio_within_15pct": sum(e <= math.log(RATIO_TOLERANCE) for e in errors)
            / max(len(exact), 1),
            "worst_ratio_error": math.exp(max(errors, default=0.0)) - 1.0,
            "worst_turn_error_deg": max(turns, default=0.0),
            "unchanged_sets": len(plain),
            "unchanged_named_nothing": sum(not r["causes"] for r in plain),
            "median_s": seconds[len(seconds) // 2] if seconds else math.nan}
