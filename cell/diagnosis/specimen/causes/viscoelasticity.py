"""Viscoelasticity: quasi-linear relaxation, the fraction that relaxes, its shares among the
terms (stick-breaking), each term's time (log10 s) within the tests' span."""

from __future__ import annotations

from typing import Any

import numpy as np

from cell.diagnosis.specimen.causes.base import Cause, Parameter, Settings


class Viscoelasticity(Cause):
    """The relaxed fraction, its shares and the terms' log10 times.

    Example:
        >>> from cell.diagnosis.specimen.causes import CandidateMaterial
        >>> [p.name for p in Viscoelasticity().parameters(CandidateMaterial())]
        ['relaxed_fraction', 'relaxation_share_0', 'log_relaxation_time_0', \
'log_relaxation_time_1']
    """

    name = "viscoelasticity"

    def parameters(self, model: Settings) -> tuple[Parameter, ...]:
        """The fraction, its shares, and the times spread evenly in log time over the
        model's range."""
        terms = model.relaxation_terms
        low, high = np.log10(model.time_range_s)
        times = np.linspace(low, high, terms + 2)[1:-1]
        return (Parameter("relaxed_fraction", 0.3, 0.0, 0.98),
                *(Parameter(f"relaxation_share_{k}", 1.0 / (terms - k), 0.0, 1.0)
                  for k in range(terms - 1)),
                *(Parameter(f"log_relaxation_time_{k}", float(t), float(low), float(high))
                  for k, t in enumerate(times)))

    def fields(self, value: dict[str, float], model: Settings) -> dict[str, Any]:
        """The relaxation's weights and times."""
        return {"relaxation_weights": _weights(value, model.relaxation_terms),
                "relaxation_times_s": tuple(10.0 ** value[f"log_relaxation_time_{k}"]
                                            for k in range(model.relaxation_terms))}


def _weights(value: dict[str, float], terms: int) -> tuple[float, ...]:
    """g_k from the relaxed fraction and its shares (stick-breaking: term k takes share k of
    what the terms before it left, the last term the rest)."""
    left = value["relaxed_fraction"]
    weights = []
    for k in range(terms - 1):
        weights.append(left * value[f"relaxation_share_{k}"])
        left -= weights[-1]
    return (*weights, left)
