"""Pinhole cameras for tests, built by hand (OpenCV's convention: x right, y down, z ahead).

Used with ``cv2.projectPoints`` as truth the code under test did not make.
"""

import numpy as np


def look_at(centre, target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)):
    """R, t of a camera at ``centre`` (m) looking at ``target``, ``up`` the world's vertical."""
    c = np.asarray(centre, float)
    z = np.asarray(target, float) - c
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    R = np.vstack([x, np.cross(z, x), z])
    return R, -R @ c
