"""``vidtrack view``: a local page to set up, check and correct a run.

The page (served on 127.0.0.1 by Flask) shows each view's footage frame by frame with the
overlay's marks, takes clicks into ``scene.toml`` and the manual points file (a throw's
corrections into its own ``throw.toml``, in a run with ``throws/``), and fits the run
again. The modules:

- ``run_view``: :class:`RunView`, the run held open: scene, footage, tracks, fitted path,
  and a frame drawn as PNG;
- ``view_data``: :class:`ViewData`, a view's corrections, tracks and fitted path, read
  once per change of the run;
- ``zoom``: :func:`zoom_image`, the footage's pixels around one pixel, magnified;
- ``edits``: :func:`apply_edit`, one edit of ``scene.toml`` checked by the scene loader and
  written in place (comments kept), atomically;
- ``fit_job``: :class:`FitJob`, ``vidtrack fit RUN`` in a child process;
- ``app``: :func:`create_app`, the Flask application and its routes;
- ``server``: :func:`start_server`, the page served on 127.0.0.1 from a thread.

Flask and tomlkit come with the ``view`` extra: ``pip install 'vidtrack[view]'``.
"""

from vidtrack._lazy import lazy_exports

_EXPORTS = {
    "vidtrack.view.app": ("create_app",),
    "vidtrack.view.server": ("start_server", "PageServer", "HOST"),
    "vidtrack.view.run_view": ("RunView",),
    "vidtrack.view.edits": ("apply_edit", "EditResult", "axes_from_clicks", "EDITS"),
    "vidtrack.view.fit_job": ("FitJob",),
}
__getattr__, __dir__, _NAMES = lazy_exports(__name__, _EXPORTS)

__all__ = ["create_app", "start_server", "PageServer", "HOST", "RunView", "apply_edit",
           "EditResult", "axes_from_clicks", "EDITS", "FitJob"]
