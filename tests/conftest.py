"""Shared fixtures; the tests' own helpers (independent references) live beside."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
