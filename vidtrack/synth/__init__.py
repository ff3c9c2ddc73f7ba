"""Synthetic runs with known truth: ``render_run(out, SynthSpec(...))`` -> ``SynthRun``.

Renders a run folder as a lab would film it (two views, ruler, blade, noise, motion blur,
compression) from known coefficients, with ``truth.json`` beside it. Defined in
``vidtrack.synth.runs``; the anti-aliased shapes are drawn by ``vidtrack.synth._raster``.
"""

from vidtrack.synth.runs import (CODECS, FORMATS, TRUTH_FILE, TRUTH_SCHEMA, VIEW_NAMES,
                                 SynthRun, SynthSpec, render_run, second_straw_state,
                                 straw_pose)

__all__ = ["SynthSpec", "SynthRun", "render_run", "VIEW_NAMES", "FORMATS", "CODECS",
           "TRUTH_FILE", "TRUTH_SCHEMA", "straw_pose", "second_straw_state"]
