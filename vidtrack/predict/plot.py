"""The figure of a prediction: front (x-y) and top (x-z) views of the predicted throw.

:func:`plot_prediction` draws a :class:`~vidtrack.predict.forward.Prediction` (the
trajectory with its 95 % band when there is one, the blade circle, the ground, the
device's inlet and O1) to a PNG; matplotlib is imported only when it is called.
"""

import numpy as np

from vidtrack.predict.coefficients import _Z95

__all__ = ["plot_prediction"]


def plot_prediction(prediction, path):
    """Write the front (x-y) and top (x-z) views of the predicted throw as a PNG.

    The 95 % band (when the regression has a covariance) is shaded; the blade circle,
    the ground and, when placed, the device's inlet and O1 are drawn. Written atomically.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vidtrack._atomic import atomic_path

    tr = prediction.trajectory
    rel = prediction.release
    x, y, z = tr.xyz_m.T
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 8), sharex=True)
    r = rel.setting.radius_m
    ang = np.linspace(0, 2 * np.pi, 200)
    ax1.plot(r * np.cos(ang), r * np.sin(ang), color="0.6", lw=0.8, label="blade circle")
    ax1.axhline(-tr.shaft_height_m, color="saddlebrown", lw=1.2, label="ground")
    ax1.plot(x, y, color="C0", label="predicted throw")
    if tr.y_sd_at_x_m is not None:
        ax1.fill_between(x, y - _Z95 * tr.y_sd_at_x_m, y + _Z95 * tr.y_sd_at_x_m,
                         color="C0", alpha=0.25, label="95 % band (k covariance)")
        ax2.fill_between(x, z - _Z95 * tr.z_sd_at_x_m, z + _Z95 * tr.z_sd_at_x_m,
                         color="C0", alpha=0.25)
    ax1.plot([rel.x0_m], [rel.y0_m], "o", color="C1", label="release")
    if prediction.device is not None:
        d = prediction.device
        ax1.plot([d.inlet_x_m] * 2, list(d.inlet_y_m), color="C2", lw=3, label="inlet")
        ax1.plot([d.h1_m], [d.h2_m], "+", color="C2", ms=10, label="O1 (H1, H2)")
    ax1.set_ylabel("y (m)")
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.legend(fontsize=8, loc="best")
    s = prediction.coefficients.setting
    ax1.set_title(f"n = {s['n_rpm']:g} r/min, delta1 = {s['blade_angle_deg']:g} deg, "
                  f"v1 = {s['speed_kmh']:g} km/h" + (" (extrapolation)"
                                                    if prediction.coefficients.extrapolation
                                                    else ""))
    ax2.plot(x, z, color="C0")
    ax2.set_xlabel("x (m)")
    ax2.set_ylabel("z relative to the machine (m)")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
