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


@pytest.fixture(autouse=True, scope="session")
def _shared_cache_of_the_session(tmp_path_factory):
    """Runs keep meshes and reduced models in the user's cache (app.cache): the tests use
    one of their own, shared by the session (a test that needs a cold cache sets its own)."""
    import os

    os.environ["MICROSLIP_CACHE"] = str(tmp_path_factory.mktemp("shared-cache"))
