"""The lattice's calibration with orthotropy: the sheets' gain on the springs, solved so that the
lattice has the material's E_s / E_n, and nothing changed for a transversely isotropic one."""

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from cell.errors import MaterialError
from cell.sim.assembly import build_scene
from cell.sim.scenario import Scenario
from cell.tissue.forces import TissueForces
from cell.tissue.geometry import MuscleShape
from cell.tissue.lattice import (
    AffineLattice,
    calibrated_law,
    calibration_factors,
    sheet_factor,
    tet_edges,
)
from cell.tissue.material import MassSpringMaterial, default_meat
from cell.tissue.tetmesh import structured_hex_tets

_GRID = np.stack(np.meshgrid(*[np.linspace(0, 0.1, 3)] * 3, indexing="ij"), -1).reshape(-1, 3)
_EDGES, _VOLUME = tet_edges(_GRID, structured_hex_tets((2, 2, 2)))


def test_a_transversely_isotropic_material_is_calibrated_as_before() -> None:
    material = default_meat()
    assert not material.orthotropic and material.sheet_direction == (0.0, 0.0, 1.0)
    _, tension, _, factor = calibrated_law(_GRID, _EDGES, _VOLUME, material, (1, 0, 1))
    assert factor == 1.0
    # The frame across the fibres is the one the calibration always took.
    lattice = AffineLattice(_GRID, _EDGES, _VOLUME, np.array([1.0, 0.0, 1.0]))
    el, et = (material.longitudinal.small_strain_modulus_pa,
              material.transverse.small_strain_modulus_pa)
    el_in, et_in = lattice.calibrated(el, et)
    assert tension == (el_in / el, et_in / et)
    assert calibration_factors(_GRID, _EDGES, _VOLUME, material, (1, 0, 1), (0, 1, 0)) == tension


@pytest.mark.parametrize("ratio", [0.4, 1.7, 2.8])
def test_the_orthotropic_lattice_has_the_materials_three_young_moduli(ratio: float) -> None:
    material = MassSpringMaterial.transversely_isotropic(2e4, 1e4, sheet_over_normal=ratio,
                                                         fibre_direction=(0.0, 0.0, 1.0),
                                                         sheet_direction=(1.0, 0.0, 0.0))
    along, sheet = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)
    factor = sheet_factor(_GRID, _EDGES, _VOLUME, material, along, sheet)
    alpha, beta = calibration_factors(_GRID, _EDGES, _VOLUME, material, along, sheet, factor)
    lattice = AffineLattice(_GRID, _EDGES, _VOLUME, np.array(along), sheet=np.array(sheet))
    el, es, en = lattice.axial_moduli(alpha * 2e4, beta * 1e4, factor)
    assert el == pytest.approx(2e4, rel=1e-9)
    assert es / en == pytest.approx(ratio, rel=1e-8)
    assert np.sqrt(es * en) == pytest.approx(1e4, rel=1e-9)
    assert (factor > 1.0) == (ratio > 1.0)


def test_an_orthotropy_beyond_the_lattices_reach_is_named() -> None:
    material = MassSpringMaterial(sheet_over_normal=20.0)
    with pytest.raises(MaterialError, match=r"sheet_over_normal.*outside"):
        sheet_factor(_GRID, _EDGES, _VOLUME, material, (1, 0, 0), (0, 0, 1))


def test_the_cells_muscles_read_the_orthotropy_from_their_material() -> None:
    scenario = Scenario(tissue=MuscleShape(cell_size_m=0.05))
    scene = build_scene(scenario, robots=False)
    material = default_meat()
    plain = TissueForces(scene.model, material, scene.aponeurosis, scene.tissue_bodies)
    orthotropic = TissueForces(scene.model, replace(material, sheet_over_normal=2.0),
                               scene.aponeurosis, scene.tissue_bodies)
    for muscle, springs in orthotropic.springs.items():
        before = plain.springs[muscle]
        assert before.sheet_factor == 1.0 and springs.sheet_factor > 1.0
        # Across the fibres (x), springs along the sheets (z) gain k over those along their
        # normal (y), whatever the calibration's common factors.
        points = springs.vertex_state(mujoco.MjData(scene.model))[0]
        d = points[springs.edges[:, 1]] - points[springs.edges[:, 0]]
        u = np.abs(d / np.linalg.norm(d, axis=1, keepdims=True))
        gain = springs.stiffness_n_m / before.stiffness_n_m
        vertical, lateral = gain[u[:, 2] > 0.999], gain[u[:, 1] > 0.999]
        assert len(vertical) and len(lateral)
        assert vertical.mean() / lateral.mean() == pytest.approx(springs.sheet_factor, rel=2e-3)
