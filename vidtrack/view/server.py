"""Serving the page on 127.0.0.1 (Werkzeug's server, which Flask runs on).

:func:`start_server` binds the app to the loopback interface only, on the port asked for
or a free one, and serves it from a thread; the caller prints the URL and waits.
"""

import threading

__all__ = ["start_server", "PageServer", "HOST"]

#: The only interface the page is served on: this machine.
HOST = "127.0.0.1"


class PageServer:
    """A running page server: its ``url``; :meth:`stop` shuts it down."""

    def __init__(self, server, thread):
        self._server, self._thread = server, thread
        self.port = server.server_port
        self.url = f"http://{HOST}:{self.port}/"

    def stop(self):
        self._server.shutdown()
        self._thread.join()
        self._server.server_close()


def start_server(app, *, port=0):
    """Serve ``app`` on 127.0.0.1 from a background thread.

    Parameters
    ----------
    app : flask.Flask
    port : int
        The port (0: a free one the system picks).

    Returns
    -------
    PageServer

    Raises
    ------
    VidtrackError
        The port is taken or cannot be bound (one line).
    """
    from werkzeug.serving import make_server

    from vidtrack.errors import VidtrackError

    try:
        server = make_server(HOST, port, app, threaded=True)
    except (OSError, SystemExit) as exc:
        raise VidtrackError(f"--port {port}: cannot serve on {HOST}:{port} ({exc}); expected "
                            "a free port, or --port 0 for any") from None
    thread = threading.Thread(target=server.serve_forever, name="vidtrack-view", daemon=True)
    thread.start()
    return PageServer(server, thread)
