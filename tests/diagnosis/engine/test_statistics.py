"""A parameter's 95 % interval is finite only where the data determine the parameter: a
parameter the fit's Jacobian does not see, or sees only traded against another, has none
(never a falsely narrow one), for every family's fits alike."""

import numpy as np

from cell.diagnosis.engine.statistics import Z95, bic, half_widths_95


def test_a_well_posed_fit_has_the_textbook_intervals() -> None:
    rng = np.random.default_rng(3)
    jacobian = rng.normal(size=(50, 3))
    expected = Z95 * np.sqrt(np.diag(np.linalg.inv(jacobian.T @ jacobian)) * 0.04)
    assert np.allclose(half_widths_95(jacobian, 0.04), expected)


def test_a_parameter_the_data_do_not_move_has_no_interval() -> None:
    jacobian = np.column_stack([np.linspace(0.0, 1.0, 20), np.zeros(20)])
    widths = half_widths_95(jacobian, 0.01)
    assert np.isfinite(widths[0]) and np.isnan(widths[1])


def test_parameters_that_trade_off_exactly_have_none_though_each_moves_the_data() -> None:
    x = np.linspace(0.0, 1.0, 30)
    jacobian = np.column_stack([x, 2.0 * x, x**2])
    widths = half_widths_95(jacobian, 0.01)
    assert np.isnan(widths[:2]).all() and np.isfinite(widths[2])


def test_the_information_criterion_rewards_a_better_fit_and_charges_each_parameter() -> None:
    assert bic(1.0, 100, 2) < bic(2.0, 100, 2)
    assert np.isclose(bic(1.0, 100, 3) - bic(1.0, 100, 2), np.log(100))
