"""Response-surface analysis of a designed experiment (Chen 2018 Table 3, eqs. 20-23).

``fit_rsm(table, response, factors)`` -> ``RsmFit``: the second-order model in coded
variables, its ANOVA (model, terms, lack of fit, pure error), backward elimination and the
canonical analysis, defined in ``fits.rsm.fit``. The private modules hold the model terms
(``_terms``), the statistics (``_stats``) and reading and checking the table (``_table``);
the summaries' text and HTML formatting is ``fits._text``, shared with ``fits.orthogonal``
and ``fits.lsq``.
"""

from fits.rsm.fit import (AliasedTermWarning, AnovaRow, CanonicalAnalysis, EliminationStep,
                          Factor, RsmFit, TermTest, code_factors, default_factors, fit_rsm,
                          read_table)

__all__ = ["AliasedTermWarning", "AnovaRow", "CanonicalAnalysis", "EliminationStep", "Factor",
           "RsmFit", "TermTest", "code_factors", "default_factors", "fit_rsm", "read_table"]
