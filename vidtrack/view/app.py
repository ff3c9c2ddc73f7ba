"""The page's Flask application: the page, the frames, the edits and the fit.

Routes (all JSON but the page and the frames):

- ``GET /``: the page (``static/view.html``);
- ``GET /api/state``: the run read again (scene.toml, tracks, fit), its views (frame
  count, size, display scale, ``target``), the scene's remaining error, notes, the fit's
  state;
- ``GET /api/frame/<view>/<index>``: the frame's number, time, flags and reason,
  measured point and corrections (:meth:`RunView.frame_info`);
- ``GET /frame/<view>/<index>.png``: the frame with the marks drawn (:meth:`RunView.render`);
- ``GET /zoom/<view>/<index>.png?u=U&v=V``: the footage's pixels around pixel (U, V),
  magnified (:meth:`RunView.zoom`);
- ``POST /api/throw``: show another throw of a run with ``throws/`` (``{"throw": "02"}``);
  answers the state;
- ``POST /api/edit``: one edit of scene.toml, or of the throw's throw.toml for a
  correction in a run with ``throws/`` (:func:`vidtrack.view.edits.apply_edit`);
- ``POST /api/fit`` starts ``vidtrack fit RUN``, ``GET /api/fit`` says how it went.

Requests that name another host than 127.0.0.1 or localhost are refused (403). Bad input
answers HTTP 400 (404 for a view or frame that is not there) with
``{"error": "<the one-line message vidtrack's commands print>"}``; nothing is written then.
"""

from pathlib import Path

from vidtrack.errors import INPUT_ERRORS, VidtrackError

__all__ = ["create_app"]

_STATIC = Path(__file__).resolve().parent / "static"
#: The host names the page answers to (it is served on 127.0.0.1 only).
LOCAL_HOSTS = ("127.0.0.1", "localhost")


def create_app(run_dir):
    """The Flask app of the page for one run folder.

    Parameters
    ----------
    run_dir : str or pathlib.Path
        The run folder (see :class:`~vidtrack.view.run_view.RunView`).

    Returns
    -------
    flask.Flask
        ``app.config["RUN_VIEW"]`` is the :class:`RunView`, ``app.config["FIT_JOB"]`` the
        :class:`FitJob`.

    Raises
    ------
    VidtrackError
        The run cannot be shown (one line; see :class:`RunView`).
    """
    from flask import Flask, jsonify, request, send_from_directory

    from vidtrack.view.edits import apply_edit
    from vidtrack.view.fit_job import FitJob
    from vidtrack.view.run_view import RunView

    run = RunView(run_dir)
    job = FitJob(run.folder, on_done=run.reload)
    app = Flask("vidtrack.view", static_folder=str(_STATIC), static_url_path="/static")
    app.config.update(RUN_VIEW=run, FIT_JOB=job, JSON_SORT_KEYS=False)

    def refused(exc, status=400):
        return jsonify({"error": str(exc)}), status

    def image(png):
        return app.response_class(png, mimetype="image/png",
                                  headers={"Cache-Control": "no-store"})

    def shown():
        """The run's state as the page shows it, and the fit's."""
        out = run.state()
        out["fit"] = job.status()
        return jsonify(out)

    @app.before_request
    def this_machine_only():
        # served on 127.0.0.1 only; a page of another site that a browser sends here
        # under another host name (DNS rebinding) is turned away
        if request.host.rsplit(":", 1)[0] not in LOCAL_HOSTS:
            return refused(f"host {request.host!r}: this page answers only as "
                           f"{' or '.join(LOCAL_HOSTS)}", 403)

    @app.get("/")
    def page():
        return send_from_directory(_STATIC, "view.html")

    @app.get("/api/state")
    def state():
        if job.status()["state"] != "running":
            try:   # scene.toml or the outputs may have changed outside the page
                run.reload()
            except INPUT_ERRORS as exc:
                return refused(exc)
        return shown()

    @app.get("/api/frame/<view>/<int:index>")
    def frame_info(view, index):
        try:
            return jsonify(run.frame_info(view, index))
        except VidtrackError as exc:
            return refused(exc, 404)

    @app.get("/frame/<view>/<int:index>.png")
    def frame_png(view, index):
        try:
            png = run.render(view, index)
        except VidtrackError as exc:
            return refused(exc, 404)
        return image(png)

    @app.get("/zoom/<view>/<int:index>.png")
    def zoom_png(view, index):
        at = (request.args.get("u", type=float), request.args.get("v", type=float))
        try:
            png = run.zoom(view, index, at)
        except VidtrackError as exc:
            return refused(exc, 404)
        except ValueError as exc:
            return refused(exc)
        return image(png)

    def json_object(where, what, fields):
        """The request's JSON object and None, or None and the refusal."""
        body = request.get_json(silent=True)
        if isinstance(body, dict):
            return body, None
        return None, refused(f"{where}: the {what} must be a JSON object {fields}")

    @app.post("/api/throw")
    def throw():
        body, no = json_object(run.folder, "request", '{"throw": ...}')
        if no:
            return no
        try:
            run.select_throw(body.get("throw"))
        except INPUT_ERRORS as exc:
            return refused(exc)
        return shown()

    @app.post("/api/edit")
    def edit():
        body, no = json_object(run.scene_path, "edit", '{"view": ..., "set": ...}')
        if no:
            return no
        if job.status()["state"] == "running":
            return refused("a fit is running; edit scene.toml when it has finished", 409)
        try:
            name = body.get("view")
            n = run.frame_count(name) if name in run.view_names else 0
            result = apply_edit(run.folder, body, n_frames=n, throw=run.throw)
        except INPUT_ERRORS as exc:
            return refused(exc)
        run.reload()
        return jsonify(result.to_dict(root=run.folder))

    @app.post("/api/fit")
    def fit_start():
        if not job.start():
            return refused("a fit is already running", 409)
        return jsonify(job.status()), 202

    @app.get("/api/fit")
    def fit_status():
        return jsonify(job.status())

    return app
