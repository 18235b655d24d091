"""Paths the tests share: the repository and its shipped scenes."""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture
def beam() -> Path:
    """The generated soft cantilever (240 tets, no downloaded data)."""
    return ROOT / "experiments" / "scenes" / "soft_beam.toml"
