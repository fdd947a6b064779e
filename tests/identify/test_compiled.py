"""choreo.identify.compiled: numpy's compiled clip and interp, or its public functions."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from choreo.identify import compiled

ANGLES = np.array([np.nan, np.inf, -np.inf, -3.0, -1.0, -0.0, 0.0, 0.4, 2.0, 7.5])


def test_they_give_what_numpys_public_functions_give():
    np.testing.assert_array_equal(compiled.clip(ANGLES, -1.0, 2.0), np.clip(ANGLES, -1.0, 2.0))
    points = np.linspace(-2.0, 2.0, 9)
    np.testing.assert_array_equal(
        compiled.interp(ANGLES, points, points**2), np.interp(ANGLES, points, points**2)
    )


@pytest.fixture
def numpy_without_its_private_modules(monkeypatch):
    monkeypatch.setattr(np, "_core", None)
    monkeypatch.setattr(np, "core", None, raising=False)
    yield importlib.reload(compiled)
    monkeypatch.undo()
    importlib.reload(compiled)


def test_a_numpy_that_moved_them_gets_its_public_functions(numpy_without_its_private_modules):
    assert numpy_without_its_private_modules.clip is np.clip
    assert numpy_without_its_private_modules.interp is np.interp
