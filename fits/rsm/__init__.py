"""Response-surface analysis of a designed experiment (Chen 2018 Table 3, eqs. 20-23).

``fit_rsm(table, response, factors)`` -> ``RsmFit``: the second-order model in coded
variables, its ANOVA (model, terms, lack of fit, pure error), backward elimination and the
canonical analysis. The fitting (factors and their coding, elimination, ``fit_rsm``) is
``fits.rsm.fit``; the result ``RsmFit`` with its tables, JSON and summaries is
``fits.rsm.results``. The private modules hold the model terms (``_terms``), the
statistics (``_stats``) and reading and checking the table (``_table``); the summaries'
text and HTML formatting is ``fits._text``, shared with ``fits.orthogonal`` and
``fits.lsq``.
"""

from fits.rsm._stats import AnovaRow, CanonicalAnalysis
from fits.rsm._table import read_table
from fits.rsm.fit import AliasedTermWarning, Factor, code_factors, default_factors, fit_rsm
from fits.rsm.results import EliminationStep, RsmFit, TermTest

__all__ = ["AliasedTermWarning", "AnovaRow", "CanonicalAnalysis", "EliminationStep", "Factor",
           "RsmFit", "TermTest", "code_factors", "default_factors", "fit_rsm", "read_table"]
