"""The worker process that tracks a view beside the command (vidtrack.run._workers):
a Ctrl-C while its interpreter starts is the command's to handle, not the worker's."""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import os, signal, time
    from vidtrack.run._workers import ViewProcess, WorkerGone

    if __name__ == "__main__":
        vp = ViewProcess()
        # SIGINT after SIGINT while the worker's interpreter starts and imports
        end = time.monotonic() + 1.0
        while time.monotonic() < end and vp.proc.is_alive():
            os.kill(vp.proc.pid, signal.SIGINT)
            time.sleep(0.005)
        vp.start(None, "nowhere", "top", {})
        try:
            vp.track()
        except WorkerGone as exc:
            print("gone:", exc)
        except Exception as exc:
            print("answered:", type(exc).__name__)
        vp.stop()
""")


def test_sigint_while_the_worker_starts_leaves_it_serving_and_silent(tmp_path):
    script = tmp_path / "start_worker.py"
    script.write_text(SCRIPT)
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    # the job (a scene that is None) failed in the worker and its error came back: the
    # worker lived through the signals and served
    assert res.stdout.strip() == "answered: AttributeError", res.stdout + res.stderr
    assert "Traceback" not in res.stderr and "KeyboardInterrupt" not in res.stderr, res.stderr
