"""Material parameters: modulus curves, the mass-spring material, material files."""

from pathlib import Path

import numpy as np
import pytest

from cell.errors import MaterialError
from cell.tissue.curves import ModulusCurve
from cell.tissue.material import ContinuumMaterial, MassSpringMaterial
from cell.tissue.materialfile import load_material, material_to_toml

# Stiffening in tension, softening in compression; positive over [0.75, 1.3].
_KNOWN = (3.0e4, 1.2e5, 4.0e5, -3.0e5, 2.0e5, 1.0e5)


def test_fit_recovers_a_known_curve() -> None:
    truth = ModulusCurve(_KNOWN, r_min=0.75, r_max=1.3)
    stretch = np.linspace(0.75, 1.3, 60)
    fitted = ModulusCurve.fit(stretch, truth.stress_pa(stretch))
    np.testing.assert_allclose(fitted.coefficients, _KNOWN, rtol=1e-6, atol=1e-3)
    assert (fitted.r_min, fitted.r_max) == (0.75, 1.3)


def test_fit_of_noisy_tension_data_follows_the_stress() -> None:
    truth = ModulusCurve(_KNOWN, r_min=0.75, r_max=1.3)
    stretch = np.linspace(1.02, 1.3, 40)
    sigma_pa = 50.0
    noise = np.random.default_rng(0).normal(0.0, sigma_pa, stretch.size)
    fitted = ModulusCurve.fit(stretch, truth.stress_pa(stretch) + noise)
    # The range is widened to the rest state.
    assert fitted.r_min == 1.0
    np.testing.assert_allclose(
        fitted.stress_pa(stretch), truth.stress_pa(stretch), atol=sigma_pa, rtol=0.01
    )


def test_constant_curve_is_linear_at_every_stretch() -> None:
    curve = ModulusCurve.constant(3.0e4)
    r = np.array([0.2, 0.9, 1.0, 1.2, 3.0])
    np.testing.assert_allclose(curve.modulus_pa(r), 3.0e4)
    np.testing.assert_allclose(curve.stress_pa(r), 3.0e4 * (r - 1.0), atol=1e-9)
    assert curve.small_strain_modulus_pa == curve.max_modulus_pa() == 3.0e4


def test_modulus_is_clamped_and_stress_continues_outside_the_range() -> None:
    curve = ModulusCurve(_KNOWN, r_min=0.75, r_max=1.3)
    assert curve.modulus_pa(2.0) == curve.modulus_pa(1.3)
    assert curve.modulus_pa(0.1) == curve.modulus_pa(0.75)
    slope = (curve.stress_pa(1.5) - curve.stress_pa(1.4)) / 0.1
    np.testing.assert_allclose(slope, curve.modulus_pa(1.3), rtol=1e-9)
    np.testing.assert_allclose(curve.stress_pa(1.3 + 1e-9), curve.stress_pa(1.3), atol=1e-3)


@pytest.mark.parametrize(
    "coefficients",
    [
        (1.0e4, -1.0e5, 0.0, 0.0, 0.0, 0.0),  # crosses zero at r = 1.1
        (1.0e2, -2.0e3, 1.0e4, 0.0, 0.0, 0.0),  # 1e4 (x - 0.1)**2: touches zero at r = 1.1
        (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    ],
)
def test_non_positive_modulus_in_range_is_rejected(coefficients: tuple[float, ...]) -> None:
    with pytest.raises(MaterialError) as error:
        ModulusCurve(coefficients, r_min=0.8, r_max=1.3)
    assert error.value.field == "coefficients"


def test_non_positive_modulus_outside_range_is_allowed() -> None:
    # The polynomial turns negative only beyond r_max, where the modulus is clamped.
    curve = ModulusCurve((1.0e4, -1.0e5, 0.0, 0.0, 0.0, 0.0), r_min=0.8, r_max=1.05)
    assert curve.modulus_pa(1.5) == pytest.approx(5.0e3)


def test_range_must_hold_the_rest_state() -> None:
    with pytest.raises(MaterialError) as error:
        ModulusCurve.constant(3.0e4, r_min=1.1, r_max=1.3)
    assert error.value.field == "r_min"


def test_zero_fibre_direction_is_rejected() -> None:
    with pytest.raises(MaterialError) as error:
        MassSpringMaterial(fibre_direction=(0.0, 0.0, 0.0))
    assert error.value.field == "fibre_direction"


def test_constructors_and_fibre_normalisation() -> None:
    paper = MassSpringMaterial.transversely_isotropic(0.25e6, 0.6e6, fibre_direction=(0, 3, 4))
    assert paper.longitudinal.small_strain_modulus_pa == 0.25e6
    assert paper.transverse.small_strain_modulus_pa == 0.6e6
    assert paper.fibre_direction == pytest.approx((0.0, 0.6, 0.8))
    iso = MassSpringMaterial.isotropic(3.0e4)
    assert iso.longitudinal == iso.transverse == ModulusCurve.constant(3.0e4)


_GOOD_MASS_SPRING = """\
model = "mass_spring"
density_kg_m3 = 1070.0
damping_s = 1e-4
fibre_direction = [0, 1, 0]

[longitudinal]
coefficients = [2.5e5, 1e6, 0, 0, 0, 0]
r_min = 0.8
r_max = 1.3

[transverse]
modulus_pa = 6e5
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "meat.toml"
    path.write_text(text)
    return path


def test_load_material_mass_spring(tmp_path: Path) -> None:
    material = load_material(_write(tmp_path, _GOOD_MASS_SPRING))
    assert isinstance(material, MassSpringMaterial)
    assert material.longitudinal == ModulusCurve((2.5e5, 1e6, 0, 0, 0, 0), 0.8, 1.3)
    assert material.transverse == ModulusCurve.constant(6e5)
    assert material.fibre_direction == (0.0, 1.0, 0.0)
    assert material.density_kg_m3 == 1070.0


def test_load_material_continuum(tmp_path: Path) -> None:
    material = load_material(_write(tmp_path, 'model = "continuum"\nyoung_pa = 4e4\n'))
    assert material == ContinuumMaterial(young_pa=4e4)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (_GOOD_MASS_SPRING.replace("modulus_pa = 6e5", "r_max = 1.4"), "transverse.modulus_pa"),
        (
            _GOOD_MASS_SPRING.replace("modulus_pa = 6e5", "modulus_pa = -6e5"),
            "transverse.modulus_pa",
        ),
        (_GOOD_MASS_SPRING.replace("[2.5e5, 1e6,", "[2.5e5, -1e7,"), "longitudinal.coefficients"),
        (_GOOD_MASS_SPRING.replace("[transverse]\nmodulus_pa = 6e5\n", ""), "transverse"),
        (_GOOD_MASS_SPRING.replace("damping_s", "dampin_s"), "dampin_s"),
        (_GOOD_MASS_SPRING.replace("r_min = 0.8", "r_low = 0.8"), "longitudinal.r_low"),
        (_GOOD_MASS_SPRING.replace("[0, 1, 0]", "[0, 0, 0]"), "fibre_direction"),
        (_GOOD_MASS_SPRING.replace("[0, 1, 0]", "[0, 1]"), "fibre_direction"),
        (_GOOD_MASS_SPRING.replace('"mass_spring"', '"springs"'), "model"),
        (_GOOD_MASS_SPRING.replace("[0, 1, 0]", "[0, 1, 0]\nsheet_over_normal = 0"),
         "sheet_over_normal"),
        (_GOOD_MASS_SPRING.replace(
            "[0, 1, 0]", "[0, 1, 0]\nsheet_over_normal = 2\nsheet_direction = [0, -2, 0]"),
         "sheet_direction"),
        ('model = "continuum"\nyoung_pa = -3e4\n', "young_pa"),
    ],
    ids=[
        "missing-modulus",
        "negative-modulus",
        "negative-polynomial",
        "missing-curve",
        "unknown-key",
        "unknown-curve-key",
        "zero-fibre",
        "short-fibre",
        "unknown-model",
        "zero-orthotropy",
        "sheet-along-fibres",
        "negative-young",
    ],
)
def test_bad_material_file_names_file_and_key(tmp_path: Path, text: str, key: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(MaterialError) as error:
        load_material(path)
    assert error.value.field == key
    assert str(error.value).startswith(f"{path}, {key}: ")


def test_shipped_default_material_file_is_the_default_meat() -> None:
    from cell.tissue.material import default_meat

    assert load_material("assets/materials/beef_default.toml") == default_meat()


def test_a_compression_oblique_factor_is_written_and_read_back(tmp_path: Path) -> None:
    material = MassSpringMaterial.transversely_isotropic(2e4, 1e4, oblique=-0.5,
                                                         oblique_compression=0.4)
    path = tmp_path / "m.toml"
    path.write_text(material_to_toml(material))
    assert load_material(path) == material
    assert material.in_compression().oblique == 0.4 and not material.symmetric
    with pytest.raises(MaterialError, match="oblique_compression"):
        MassSpringMaterial(oblique_compression=-1.0)


def test_a_non_linear_relaxation_is_written_and_read_back(tmp_path: Path) -> None:
    material = MassSpringMaterial(relaxation_weights=(0.3,), relaxation_times_s=(2.0,),
                                  relaxation_strain_slope=4.0, relaxation_reference_strain=0.15)
    path = tmp_path / "m.toml"
    path.write_text(material_to_toml(material))
    assert load_material(path) == material
    with pytest.raises(MaterialError, match="relaxation_reference_strain"):
        MassSpringMaterial(relaxation_reference_strain=-0.1)


def test_an_orthotropic_material_is_written_and_read_back(tmp_path: Path) -> None:
    material = MassSpringMaterial.transversely_isotropic(2e4, 1e4, sheet_over_normal=1.8,
                                                         sheet_direction=(1.0, 0.0, 2.0))
    # Made orthogonal to the fibres (x) and normalised.
    assert material.sheet_direction == (0.0, 0.0, 1.0) and material.orthotropic
    text = material_to_toml(material)
    assert "sheet_over_normal = 1.8" in text
    path = tmp_path / "m.toml"
    path.write_text(text)
    assert load_material(path) == material


def test_a_transversely_isotropic_material_is_written_as_before() -> None:
    material = MassSpringMaterial()
    assert not material.orthotropic and "sheet" not in material_to_toml(material)
    # Fibres along the default sheet direction are fine while the sheets do not matter.
    assert MassSpringMaterial(fibre_direction=(0.0, 0.0, 1.0)).sheet_direction == (0.0, 0.0, 1.0)
