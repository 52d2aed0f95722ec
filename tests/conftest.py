"""Shared fixtures; the tests' own helpers (independent references) live beside."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import pytest  # noqa: E402


@pytest.fixture(autouse=True)
def _process_allocator_untouched(monkeypatch):
    """The CLI entry points tune glibc's allocator for the whole process
    (linalg.retain_freed_memory); tests calling them in-process must not change pytest's."""
    monkeypatch.setenv("MICROSLIP_RETAIN_MEMORY", "0")
