"""Dotted key paths into a case table: ``contacts.wall.n0``, ``loads.0.amplitude``,
``assembly.contacts.damper_left.mu``; a table of an array is picked by its ``name`` or its
index. ``set`` overrides and family keys are such paths."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def _resolve(data, part: str):
    if isinstance(data, list):
        for item in data:
            if isinstance(item, dict) and item.get("name") == part:
                return item
        return data[int(part)]
    return data[part]


def get_path(data: dict, key: str) -> Any:
    """The value at ``key``; KeyError, IndexError, TypeError or ValueError if none."""
    if not isinstance(key, str) or not key or key.startswith("analysis"):
        raise KeyError(key)
    node = data
    for part in key.split("."):
        node = _resolve(node, part)
    return node


def set_path(data: dict, key: str, value: Any, create: bool = False) -> None:
    """Set ``key`` in place; ``create``: a key new to an existing table is added."""
    parts = key.split(".")
    node = data
    for part in parts[:-1]:
        node = _resolve(node, part)
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        if last not in node and not create:
            raise KeyError(key)
        node[last] = value


def parameter_keys(data: Mapping[str, Any], name: str) -> list[str]:
    """The case keys an uncertain parameter sets: a dotted name itself, a plain one that key
    of every contact ([[assembly.contacts]], or [[contacts]] of a lumped case)."""
    if "." in name:
        return [name]
    assembly = "assembly" in data
    tables = data["assembly"].get("contacts", []) if assembly else data.get("contacts", [])
    prefix = "assembly.contacts" if assembly else "contacts"
    return [f"{prefix}.{i}.{name}" for i in range(len(tables))]
