"""Progress lines of long stages: how much is left."""

from __future__ import annotations


def time_left(elapsed: float, fraction: float) -> str:
    """"~N s left" for the rest of a job of which ``fraction`` took ``elapsed`` seconds (the
    rate so far); minutes or hours past two of the smaller unit; "" before any progress or
    once done."""
    if not (0.0 < fraction < 1.0 and elapsed > 0.0):
        return ""
    left = elapsed * (1.0 - fraction) / fraction
    if left < 120:
        return f"~{left:.0f} s left"
    return f"~{left / 60:.0f} min left" if left < 7200 else f"~{left / 3600:.1f} h left"
