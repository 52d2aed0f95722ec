"""``results.h5``: what a run computed, written once and read by everything after it.

schema      the layout: every group, dataset and attribute name
writer      the writer (atomic, partial on interrupt), opening, the ``show`` summary
compare     two results files compared dataset by dataset (``microslip compare``)
"""
