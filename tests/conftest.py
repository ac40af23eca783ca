"""Shared fixtures: the reference data folder ../shared/data (skip with a reason if absent).

Under CI (``CI=true``) a missing folder is an error, not a skip: the reference-data tests are
the parity checks (Stable32, NIST, R avar, GMWM), and a clone placed elsewhere would otherwise
pass without them.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path of ../shared/data; tests that need it skip when it is not beside the repo."""
    if not SHARED_DATA.is_dir():
        if os.environ.get("CI", "").lower() in {"1", "true", "yes"}:
            pytest.fail(
                f"reference data folder {SHARED_DATA} not found: CI must put ../shared beside "
                "the repository (unset CI to skip these tests locally)"
            )
        pytest.skip(f"reference data folder {SHARED_DATA} not found (CI puts it beside the repo)")
    return SHARED_DATA
