"""What the equation labels in plots, help texts and docs stand for.

A label such as ``W (33)`` follows the name of a quantity (never stands alone) and points to
an equation of one of the papers the tracker follows; docs/theory.md lists them under
References.

>>> "W (33)" in LABELS_NOTE and "docs/theory.md" in LABELS_NOTE
True
"""

__all__ = ["LABELS_NOTE"]

#: Where a reader finds what the equation labels of the titles stand for.
LABELS_NOTE = ("Labels such as W (33) are equation numbers of the papers the tracker follows: W = Wang et al. 2013, "
               "C = Cao & Xuan 2014 (docs/theory.md, References)")
