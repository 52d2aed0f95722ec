"""``results.h5``: what a run computed, written once and read by everything after it.

file        the writer (atomic, partial on interrupt), opening, the ``show`` summary
compare     two results files compared dataset by dataset (``microslip compare``)
"""
