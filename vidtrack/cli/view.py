"""``vidtrack view``: a local page to set up, check and correct a run."""

HELP = "a local web page to set up, check and correct a run by clicking on its footage"

DESCRIPTION = """\
Serve a page on this machine only (http://127.0.0.1:PORT/) that shows each view's
footage frame by frame with what vidtrack drew in the overlay: the scene's origin O,
axes and ruler, the measured point in its flag colour with the flag names and their
reason, its trail, the fitted path, and the corrections (a point placed by hand as a
square, the target as a diamond, EXCLUDED in the banner).

Click on the frame to set the origin, the axes (a point along +X, then along +Y or +Z),
the ruler (its two ends; the length from the box beside it), the target, or a point by
hand; type the capture fps; exclude or include the frame shown; fit the run again
('vidtrack fit RUN', its one-line message shown in the page). Each edit is checked as
'vidtrack fit' checks scene.toml and written at once (the file edited in place: your
comments stay); what it refuses is shown as the same one-line message, and nothing is
written. Points by hand go to the view's manual_points file (<view>_manual.csv unless
scene.toml names one), excluded frames to exclude_frames. A click on the zoom beside the
frame places the point at the pixel the zoom shows there.

A run with throws/ is shown one throw at a time (pick it at the top): its target,
points by hand and excluded frames go to that throw's folder (throws/02/throw.toml and
its manual points file), the origin, axes, ruler and fps to the run's scene.toml.

A scene.toml that 'vidtrack init' wrote can be filled in here: the page opens while the
file does not load yet, and says what is still missing.

The URL is printed; the page opens in your browser unless --no-browser. Stop with Ctrl-C.
Needs Flask: pip install 'vidtrack[view]'.

Examples:
  vidtrack view runs/07
  vidtrack view runs/07 --port 8765 --no-browser
"""

#: Highest TCP port.
MAX_PORT = 65535

#: How often (s) the waiting main thread wakes to see a Ctrl-C.
WAKE_S = 0.2


def add_arguments(parser):
    parser.add_argument("run", metavar="RUN", help="the run folder (with scene.toml), e.g. "
                                                   "runs/07")
    parser.add_argument("--port", metavar="N", type=int, default=0,
                        help="the port on 127.0.0.1 (default 0: a free one), e.g. --port 8765")
    parser.add_argument("--no-browser", action="store_true",
                        help="print the URL only; do not open a browser")


def run(args):
    import threading

    from vidtrack.errors import VidtrackError

    if not 0 <= args.port <= MAX_PORT:
        raise VidtrackError(f"--port {args.port}: expected a port from 1 to {MAX_PORT}, or 0 "
                            "for a free one")
    try:
        import flask  # noqa: F401
    except ImportError:
        raise VidtrackError("vidtrack view needs Flask, which is not installed: pip install "
                            "'vidtrack[view]'") from None
    import logging

    from vidtrack.view import create_app, start_server

    if not args.verbose:   # the server's line per request only with -v
        logging.getLogger("werkzeug").setLevel(logging.WARNING)

    app = create_app(args.run)
    server = start_server(app, port=args.port)
    print(f"vidtrack view: {app.config['RUN_VIEW'].folder} at {server.url} (Ctrl-C stops)",
          flush=True)
    if not args.no_browser:
        import webbrowser

        webbrowser.open(server.url)
    try:
        # (woken now and then: a Ctrl-C that the kernel hands to another thread, one of
        # OpenCV's, only sets a flag, which the main thread reads when it wakes)
        idle = threading.Event()
        while not idle.wait(WAKE_S):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
        app.config["RUN_VIEW"].close()
    return 0
