"""Contact states, defined once: per sample of a period (what the return map and the time
integration decide at each instant) and per contact point over a whole period (what the
results, legends and maps show). Two enumerations with distinct names, as one point's
period holds many samples."""

# per sample: the return map's decision at one instant
SAMPLE_STICK, SAMPLE_SLIP, SAMPLE_OPEN = 0, 1, 2

# per contact point over a period: stuck throughout; stuck and slipping in turn; slipping
# throughout; in contact part of the period only; never in contact
STICK, STICK_SLIP, GROSS_SLIP, PARTIAL_LIFTOFF, OPEN = range(5)
STATE_NAMES = ("stick", "stick-slip", "gross slip", "partial lift-off", "open")
