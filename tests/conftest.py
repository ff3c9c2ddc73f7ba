"""Shared test fixtures: the real CLI as a subprocess, and where ../shared is."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import vidtrack.cli  # noqa: E402,F401  (sets one BLAS thread, as the CLI does, before numpy loads)

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


@pytest.fixture(scope="session")
def shared_dir():
    """``../shared`` beside the checkout: the project's third-party reference material
    (real footage and calibrations that may not be copied into the project). CI has it;
    on a plain clone the tests that need it skip, saying so."""
    if not SHARED.is_dir():
        pytest.skip(f"needs ../shared beside the checkout (real third-party footage that is "
                    f"not part of the project); not found at {SHARED}")
    return SHARED


@pytest.fixture(scope="session")
def real_footage(shared_dir):
    """``../shared/data/real``: public clips no one on this project made, with references
    made by others (skips, saying so, where it is not there)."""
    folder = shared_dir / "data" / "real"
    if not folder.is_dir():
        pytest.skip(f"no real footage at {folder}")
    return folder


def run_vidtrack(*args, cwd=None, timeout=600, env=None):
    """Run ``python -m vidtrack ARGS`` as a subprocess; return the CompletedProcess."""
    full_env = dict(os.environ)
    full_env.setdefault("MPLBACKEND", "Agg")
    if env:
        full_env.update(env)
    return subprocess.run([sys.executable, "-m", "vidtrack", *map(str, args)],
                          cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env=full_env, stdin=subprocess.DEVNULL)


@pytest.fixture
def vidtrack_cli():
    """The real command line, run as a subprocess: ``vidtrack_cli("anova", "t.csv")``."""
    return run_vidtrack


#: The issue's tolerances on k1..k4 (relative): 3 %, and 5 % on k4.
K_TOLERANCES = (("k1", 0.03), ("k2", 0.03), ("k3", 0.03), ("k4", 0.05))


def assert_k_within(record, truth_k):
    """Every coefficient of a fit record (``vidtrack fit --json``) determined and within
    :data:`K_TOLERANCES` of ``truth_k`` ({"k1": ..}); returns the coefficients."""
    import pytest

    out = {}
    for k, tol in K_TOLERANCES:
        c = record["coefficients"][k]
        assert c["determined"], (k, c)
        assert c["value"] == pytest.approx(truth_k[k], rel=tol), k
        out[k] = c
    return out
