"""Fitting the run again from the page: ``vidtrack fit RUN`` in a child process.

The fit the page starts is the command line's own (``python -m vidtrack fit RUN``), so
it checks, caches and writes exactly as ``vidtrack fit`` does; the page stays responsive
while it runs. :class:`FitJob` keeps its state: ``idle``, ``running``, ``done`` or
``failed`` with the command's one-line message (its last line on stderr).
"""

import subprocess
import sys
import threading
from pathlib import Path

__all__ = ["FitJob", "FIT_STATES"]

#: The states of a fit started from the page.
FIT_STATES = ("idle", "running", "done", "failed")


class FitJob:
    """One run's fit, started from the page, at most one at a time.

    Parameters
    ----------
    folder : pathlib.Path
        The run folder.
    on_done : callable, optional
        Called (without arguments) after a fit that exited 0, before the state says
        ``done`` (the page reloads the tracks there).
    """

    def __init__(self, folder, on_done=None):
        self.folder = Path(folder)
        self.on_done = on_done
        self._lock = threading.Lock()
        self._state, self._message, self._thread = "idle", None, None

    def start(self):
        """Start the fit; False when one is already running."""
        with self._lock:
            if self._state == "running":
                return False
            self._state, self._message = "running", None
            self._thread = threading.Thread(target=self._run, name="vidtrack-view-fit",
                                            daemon=True)
            self._thread.start()
            return True

    def _run(self):
        cmd = [sys.executable, "-m", "vidtrack", "fit", str(self.folder), "--quiet"]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        except OSError as exc:
            self._finish("failed", f"vidtrack fit could not be started: {exc}")
            return
        lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
        if done.returncode == 0:
            try:
                if self.on_done is not None:
                    self.on_done()
            except Exception as exc:  # the page shows it; the fit itself succeeded
                self._finish("failed", f"fitted, but the page could not read the result: "
                                       f"{exc}")
                return
            out = [ln for ln in done.stdout.splitlines() if ln.strip()]
            self._finish("done", out[-1] if out else "fitted")
        else:
            self._finish("failed", lines[-1] if lines else
                         f"vidtrack fit exited with code {done.returncode}")

    def _finish(self, state, message):
        with self._lock:
            self._state, self._message = state, message

    def wait(self, timeout=None):
        """Wait for a running fit to end (tests, the command's shutdown)."""
        thread = self._thread
        if thread is not None:
            thread.join(timeout)

    def status(self):
        """``{"state": ..., "message": ...}`` for the page."""
        with self._lock:
            return {"state": self._state, "message": self._message}
