"""Benchmarks: error against run time, side by side with the alternatives, in one run.

``vidtrack bench model`` (throw models and the blade slide), ``vidtrack bench track``
(the tracker against decode-only, trackpy and an OpenCV tracker), ``vidtrack bench track
--real`` (the tracker scoreboard: each engine on the real clips of a folder given with
``--shared`` and the synthetic distractor scenes, against references made by others; :mod:`.real`,
:mod:`.scenes`). Each writes a CSV (and most a PNG) into the output folder and prints a
table. Benchmarks never gate CI on a wall-clock figure: they report ratios measured in
the same run.
"""
