"""The bag tests' shared fixture: the crank-rocker scene file (test_bag.py holds the helpers
every bag test file imports)."""

from __future__ import annotations

from test_bag import scene  # noqa: F401  (a fixture: every file of test/bag takes it by name)
