"""A results folder a person can open: one self-contained HTML page per run, drawn from its
results.h5 alone (``microslip report``, written by every ``run``), and an index page over
several runs (a course of the teaching cases).

page         the page of one results file: the case, its status, each analysis with its
             pictures, captions and key numbers, the interactive FRFs
numbers      the key numbers of each analysis type as tables
captions     what each picture draws, in words
interactive  the FRFs' points as data for the page's plot (hover, hide, zoom)
index        the index page over several results folders
"""

from .index import write_index
from .page import write_report

__all__ = ["write_index", "write_report"]
