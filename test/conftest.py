"""Shared fixtures. The helpers behind them live in scenes.py (importable by module-level code
such as parametrize lists, which fixtures cannot reach)."""

from __future__ import annotations

import pytest
import scenes


@pytest.fixture
def config_dir():
    """The repository's config/ folder (shipped scenes)."""
    return scenes.CONFIG


@pytest.fixture
def shipped():
    """Load a shipped scene's mechanism by file stem."""
    return scenes.load
