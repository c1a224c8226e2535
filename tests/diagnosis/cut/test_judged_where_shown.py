"""A cause that acts only while the edge slides along itself (slicing, the edge's friction) is
judged on the tests that saw: on a press cut its held-out error can only tie."""

from __future__ import annotations

import numpy as np

from cell.diagnosis.cut.causes import CutCandidate
from cell.diagnosis.cut.fitting import CutProblem
from cell.diagnosis.cut.reduced import CutKinematics
from cell.diagnosis.cut.search import CutSearch
from cell.diagnosis.engine.settings import DiagnosisParams
from cell.measure.cuts import CutTest
from cell.tissue.cutmodel import CuttingParams
from tests.cutsets import BLADE, BLOCK, cut_set, press, saw


def _kinematics(path: tuple[np.ndarray, np.ndarray]) -> CutKinematics:
    t, edge = path
    return CutKinematics.of(CutTest("path", t, edge, np.zeros_like(edge)), BLOCK, BLADE)


def test_a_press_cut_does_not_slide_and_a_sawing_cut_does():
    assert not _kinematics(press(0.01)).slides
    assert _kinematics(saw(0.004)).slides


def test_a_cause_that_needs_the_edge_to_slide_is_judged_on_the_sawing_tests_alone():
    truth = CuttingParams(900.0, face_pressure_pa=1600.0, edge_friction=0.7,
                          edge_slip_m=0.003)
    tests = cut_set(truth, paths=[press(0.005), press(0.01), saw(0.004), press(0.03),
                                  saw(0.008)])
    problem = CutProblem.of(BLOCK, BLADE, tests, 100)
    search = CutSearch(problem, DiagnosisParams(), CutCandidate((), 0.01, BLOCK.top_z_m))
    baseline = search.run([(None, None)])[0]
    judged = CutSearch.rules.judged
    edge, slicing, faces = search.run([(baseline, c) for c in
                                       ("edge_friction", "slicing", "blade_friction")])
    assert judged(edge, baseline, problem.tests) == [2, 4]
    assert judged(slicing, baseline, problem.tests) == [2, 4]
    assert judged(faces, baseline, problem.tests) == [0, 1, 2, 3, 4]
    # removed, a cause is judged the same way: the richer model is the one with it
    assert judged(edge, search.run([(edge, "edge_friction")])[0], problem.tests) == [2, 4]
