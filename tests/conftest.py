"""Test-wide settings: numpy floating-point errors raise (divide, overflow, invalid)."""

import numpy as np
import pytest


@pytest.fixture(autouse=True)
def _numpy_errors_raise():
    old = np.seterr(divide="raise", over="raise", invalid="raise", under="ignore")
    yield
    np.seterr(**old)


@pytest.fixture
def table_cache(tmp_path, monkeypatch):
    """An empty, private table cache for one test."""
    root = tmp_path / "tables"
    monkeypatch.setenv("SHIPRADAR_TABLES", str(root))
    return root
