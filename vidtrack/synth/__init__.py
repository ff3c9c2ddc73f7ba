"""Synthetic runs with known truth: ``render_run(out, SynthSpec(...))`` -> ``SynthRun``.

Renders a run folder as a lab would film it (two views, ruler, blade, noise, motion blur,
compression) from known coefficients, with ``truth.json`` beside it. The modules:

- ``spec``: :class:`SynthSpec`, every parameter, and its checks; the view, format and
  codec names;
- ``motion``: what moves where at time t, in metres: the throws, :func:`straw_pose`,
  :func:`second_straw_state`, the rotor's rate;
- ``_views``: each view's framing (scale, origin, ruler) and its static image;
- ``_cameras``: pinhole cameras (``cameras = "perspective"`` at any angle, ``"square"``
  the orthogonal rig at a finite distance): placement, framing, the straw in
  perspective, the lens, their truth and scene;
- ``_renderer``: the frames of a view: poses in pixels, motion blur, anti-aliasing, noise;
- ``_raster``: the anti-aliased shapes, texture, compositing and sensor noise it draws with;
- ``_writers``: the footage: AVI, png folders, Phantom .cine;
- ``truth``: ``truth.json``;
- ``runs``: :func:`render_run` and :class:`SynthRun`, the run folder.
"""

from vidtrack.synth.motion import second_straw_state, straw_pose
from vidtrack.synth.runs import SynthRun, check_out_dir, render_run
from vidtrack.synth.spec import CODECS, FORMATS, VIEW_NAMES, SynthSpec
from vidtrack.synth.truth import TRUTH_FILE, TRUTH_SCHEMA

__all__ = ["SynthSpec", "SynthRun", "render_run", "check_out_dir", "VIEW_NAMES", "FORMATS",
           "CODECS", "TRUTH_FILE", "TRUTH_SCHEMA", "straw_pose", "second_straw_state"]
