"""The straw's slide along a rotating blade before release (Chen et al. 2018, eqs. 1-10).

Symbols (Chen 2018, section 2.1 and Fig. 2; our reading where the paper is terse)
---------------------------------------------------------------------------------
``n``       blade speed, r/min; ``omega = pi n / 30`` rad/s.
``R``       blade (tip) radius, m: the radius the tip turns on.
``delta1``  blade rake angle (刀刃倾角), rad: the angle between the blade edge and the
            radius through its tip. ``delta1 > 0``: the blade leans back against the
            rotation (后倾); ``delta1 < 0``: it leans forward (前倾); 0: radial blade.
``r0``      distance from the shaft O to the line of the blade edge: ``r0 = R sin delta1``
            (signed). O' is the foot of the perpendicular from O to that line and is the
            origin of the moving coordinate ``l`` along the edge, outward positive.
``rho``     the straw's distance from the shaft; ``delta`` the angle between the
            centrifugal force (along the radius through the straw) and the edge, so that
            ``l = rho cos(delta)`` and ``rho sin(delta) = r0``.
``alpha0``  initial phase (初相位): the blade's angle at the impact, ``t = 0``. Our
            reading, fixed by eq. 1 (``beta``) and eq. 10 (``theta``) together: the blade
            turns counter-clockwise in the XOY plane of the world frame (X outward, Y up),
            so its lowest point moves outward; ``alpha0`` is measured from the blade
            pointing straight down, in the direction of rotation. At blade angle
            ``alpha0 + omega t`` the tip's velocity makes that angle with +X.
``alpha``   the angle the blade has turned since the impact, ``alpha = omega t``.
``beta``    the angle between gravity and the edge, ``beta = alpha0 + alpha - delta1``.
``mu``      equivalent friction coefficient between straw and blade; ``phi = atan(mu)``
            the friction angle (摩擦角). Not to be confused with the paper's throw angle.
``l1``      the straw's moving coordinate at the impact, m; ``dl/dt = 0`` there
            (inelastic impact, assumption 1 of the paper).
``phi_throw`` (the paper's 抛出角 ``ϕ = omega t0``): the angle the blade turns between
            impact and release; we call it ``rotation_rad``.

The motion (eq. 1), with ``rho cos(delta) = l`` and ``rho sin(delta) = R sin(delta1)``::

    l'' + 2 mu omega l' - omega^2 l = mu omega^2 R sin(delta1) + g (cos beta - mu sin beta)
                                    = mu omega^2 R sin(delta1)
                                      + g cos(omega t + alpha0 - delta1 + phi) / cos(phi)

is linear with constant coefficients. Its characteristic roots are
``omega lambda_{1,2}`` with ``lambda_{1,2} = -mu +- sqrt(1 + mu^2)`` (eq. 2), and its
exact solution is eq. 2's form::

    l = C1 exp(lambda1 omega t) + C2 exp(lambda2 omega t)
        + D cos(omega t + alpha0) + M sin(omega t + alpha0) - mu R sin(delta1)

with D and M as printed, but with (derived here from l(0) = l1, l'(0) = 0)::

    C1 = g/(4 omega^2) (cos(2 phi - delta1 + alpha0) - sin(phi - delta1 + alpha0))
         + (1 + sin phi)/2 (l1 + mu R sin delta1)
    C2 = g/(4 omega^2) (cos(2 phi - delta1 + alpha0) + sin(phi - delta1 + alpha0))
         + (1 - sin phi)/2 (l1 + mu R sin delta1)

The paper prints C2 with ``- sin(...)``; eq. 2 as printed therefore misses its own
initial condition by ``-g sin(alpha0 - delta1 + phi) / (2 omega^2)`` (-1.36 mm in the
slide check of docs/predict.md), an error that decays as ``exp(lambda2 omega t)``.
Eq. 3 is the Taylor series of the exact solution to second order, ``l1 + a0 t^2 / 2``
with ``a0 = l''(0)``; it ignores the Coriolis friction ``-2 mu omega l'`` and so
overestimates the slide (8.7 % at t = 20 ms in that case).

Release (eq. 8): the straw leaves at the tip, ``l = R cos(delta1)`` (``rho = R``); here
found by root finding on the exact solution. Relative speed (eq. 4) ``v_r = l'(t0)``,
transport speed ``v_e = omega R``, absolute speed (eq. 9)
``v_a = sqrt(v_r^2 + v_e^2 - 2 v_r v_e sin delta1)`` and the angle of the absolute
velocity with +X (eq. 10) ``theta = alpha0 + phi_throw - atan(v_r cos delta1 /
(v_e - v_r sin delta1))`` (``atan2``, so that a release with ``v_r sin delta1 > v_e``
is still right). The release point in the world frame (origin at the shaft) is the tip,
``(x0, y0) = R (sin tau, -cos tau)`` with ``tau = alpha0 + phi_throw``.

The throwing conditions of the paper are eq. 5 (the straw starts outward,
``a0 > 0``), eq. 6 (``omega > omega_min``, which makes eq. 5 hold at every phase) and
eq. 7 (a forward-raked blade must satisfy ``mu R sin delta1 + l1 > 0``). We add the
exact one, "eq. 8 (exact)": the exact slide reaches the tip with ``l' > 0`` all along
(eq. 1's friction acts inward only while the straw moves outward).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from fits.errors import InputError

G_STANDARD = 9.80665
METHODS = ("exact", "series")

#: The slide is searched for a release over this many blade revolutions.
MAX_REVOLUTIONS = 2.0
_GRID_PER_REVOLUTION = 2000

__all__ = ["G_STANDARD", "METHODS", "BladeSetting", "SlideConstants", "ThrowCondition",
           "Release", "slide_constants", "printed_constants", "slide_position",
           "slide_speed", "slide_eq2_printed", "slide_eq3_series", "slide_eq4_series",
           "slide_ode", "initial_acceleration", "omega_min", "throwing_conditions",
           "release"]


# ---------------------------------------------------------------- the setting

def _finite(name, value):
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


@dataclass(frozen=True)
class BladeSetting:
    """A blade and the straw's start on it (Chen 2018, eq. 1 and its symbol list).

    Parameters
    ----------
    n_rpm : float
        Blade speed n, r/min (> 0).
    blade_angle_deg : float
        Rake angle delta1, degrees (-90 < delta1 < 90; > 0 leans back).
    radius_m : float
        Tip radius R, m (> 0). Default 0.25 (an assumption; not published).
    start_m : float
        The straw's moving coordinate at the impact, l1, m; must lie inside the blade,
        ``l1 < R cos(delta1)``. Default 0.10 (an assumption; not published).
    friction : float
        Equivalent friction coefficient mu (>= 0). Default 0.5 (an assumption; not published).
    phase_deg : float
        Initial phase alpha0, degrees (the blade's angle from straight down at the impact,
        in the direction of rotation). Default -30: not published; our assumption that
        the blade meets the straw shortly before its lowest point, where it enters the
        straw layer (a 0.25 m tip working 50 mm deep, section 3.2, enters the soil at
        -37 deg). The slide check of docs/predict.md uses 30.
    g_m_s2 : float
        Gravity, m/s^2.

    Raises
    ------
    fits.errors.InputError
        A value that is not finite or out of range, named with what was expected.
    """

    n_rpm: float
    blade_angle_deg: float
    radius_m: float = 0.25
    start_m: float = 0.10
    friction: float = 0.5
    phase_deg: float = -30.0
    g_m_s2: float = G_STANDARD

    def __post_init__(self):
        for name in ("n_rpm", "blade_angle_deg", "radius_m", "start_m", "friction",
                     "phase_deg", "g_m_s2"):
            object.__setattr__(self, name, _finite(name, getattr(self, name)))
        if self.n_rpm <= 0:
            raise InputError(f"n_rpm must be > 0 r/min, got {self.n_rpm}")
        if not -90.0 < self.blade_angle_deg < 90.0:
            raise InputError("blade_angle_deg must lie between -90 and 90 degrees, "
                             f"got {self.blade_angle_deg}")
        if self.radius_m <= 0:
            raise InputError(f"radius_m must be > 0 m, got {self.radius_m}")
        if self.friction < 0:
            raise InputError(f"friction must be >= 0, got {self.friction}")
        if self.g_m_s2 <= 0:
            raise InputError(f"g_m_s2 must be > 0 m/s^2, got {self.g_m_s2}")
        if self.start_m >= self.tip_m:
            raise InputError(
                f"start_m (l1) must be below the tip's coordinate R cos(delta1) = "
                f"{self.tip_m:.6g} m, got {self.start_m}")

    @property
    def omega_rad_s(self):
        """Angular speed omega = pi n / 30, rad/s."""
        return math.pi * self.n_rpm / 30.0

    @property
    def delta1_rad(self):
        """Rake angle delta1 in rad."""
        return math.radians(self.blade_angle_deg)

    @property
    def alpha0_rad(self):
        """Initial phase alpha0 in rad."""
        return math.radians(self.phase_deg)

    @property
    def friction_angle_rad(self):
        """Friction angle phi = atan(mu), rad."""
        return math.atan(self.friction)

    @property
    def r0_m(self):
        """Signed distance from the shaft to the edge's line, r0 = R sin(delta1), m."""
        return self.radius_m * math.sin(self.delta1_rad)

    @property
    def tip_m(self):
        """The tip's moving coordinate, R cos(delta1), m (eq. 8)."""
        return self.radius_m * math.cos(self.delta1_rad)

    def to_dict(self):
        """The setting as plain JSON-ready values."""
        return {"n_rpm": self.n_rpm, "blade_angle_deg": self.blade_angle_deg,
                "radius_m": self.radius_m, "start_m": self.start_m,
                "friction": self.friction, "phase_deg": self.phase_deg,
                "g_m_s2": self.g_m_s2}


# ---------------------------------------------------------------- eq. 2, exact and printed

@dataclass(frozen=True)
class SlideConstants:
    """The constants of eq. 2: ``l = C1 e^(lambda1 w t) + C2 e^(lambda2 w t)
    + D cos(w t + alpha0) + M sin(w t + alpha0) + offset_m``; lengths in m."""

    lambda1: float
    lambda2: float
    c1_m: float
    c2_m: float
    d_m: float
    m_m: float
    offset_m: float

    def to_dict(self):
        """Plain JSON-ready values."""
        return {"lambda1": self.lambda1, "lambda2": self.lambda2, "c1_m": self.c1_m,
                "c2_m": self.c2_m, "d_m": self.d_m, "m_m": self.m_m,
                "offset_m": self.offset_m}


def _common(s):
    w = s.omega_rad_s
    mu = s.friction
    root = math.hypot(1.0, mu)
    lam1 = 1.0 / (mu + root)          # -mu + sqrt(1 + mu^2), without cancellation
    lam2 = -(mu + root)
    phi = s.friction_angle_rad
    d1 = s.delta1_rad
    a0 = s.alpha0_rad
    q = s.g_m_s2 / (2.0 * w * w)      # g / (2 omega^2), m
    d = -q * math.cos(2.0 * phi - d1)
    m = q * math.sin(2.0 * phi - d1)
    shift = s.start_m + mu * s.r0_m   # l1 + mu R sin(delta1)
    return w, lam1, lam2, phi, d1, a0, q, d, m, shift


def slide_constants(setting):
    """The exact constants of eq. 2 for ``setting`` (C1, C2 from l(0) = l1, l'(0) = 0).

    Parameters
    ----------
    setting : BladeSetting

    Returns
    -------
    SlideConstants

    Notes
    -----
    With ``S = C1 + C2 = l1 + mu R sin(delta1) + q cos(alpha0 - delta1 + 2 phi)`` and
    ``P = lambda1 C1 + lambda2 C2 = -q sin(alpha0 - delta1 + 2 phi)``, ``q = g/(2 w^2)``:
    ``C1 = (1 + sin phi)/2 S + cos(phi)/2 P`` and ``C2 = (1 - sin phi)/2 S - cos(phi)/2 P``,
    which simplify to the forms in the module docstring. ``1 - sin phi`` is evaluated
    as ``cos^2 phi / (1 + sin phi)``.
    """
    w, lam1, lam2, phi, d1, a0, q, d, m, shift = _common(setting)
    s_sum = shift + q * math.cos(a0 - d1 + 2.0 * phi)
    p_sum = -q * math.sin(a0 - d1 + 2.0 * phi)
    sp, cp = math.sin(phi), math.cos(phi)
    c1 = 0.5 * (1.0 + sp) * s_sum + 0.5 * cp * p_sum
    c2 = 0.5 * (cp * cp / (1.0 + sp)) * s_sum - 0.5 * cp * p_sum
    return SlideConstants(lam1, lam2, c1, c2, d, m, -setting.friction * setting.r0_m)


def printed_constants(setting):
    """The constants of eq. 2 exactly as printed (C2 with ``- sin(phi - delta1 + alpha0)``).

    Returns
    -------
    SlideConstants
        Differs from :func:`slide_constants` only in ``c2_m``, by
        ``-g sin(alpha0 - delta1 + phi) / (2 omega^2)``.
    """
    w, lam1, lam2, phi, d1, a0, q, d, m, shift = _common(setting)
    g_part = 0.5 * q * (math.cos(2.0 * phi - d1 + a0) - math.sin(phi - d1 + a0))
    c1 = g_part + 0.5 * (1.0 + math.sin(phi)) * shift
    c2 = g_part + 0.5 * (1.0 - math.sin(phi)) * shift
    return SlideConstants(lam1, lam2, c1, c2, d, m, -setting.friction * setting.r0_m)


def _times(t):
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(t)):
        raise InputError("t must be finite")
    if np.any(t < 0):
        raise InputError(f"t must be >= 0 s (t = 0 is the impact), got min {np.min(t)}")
    return t


def _eval_eq2(t, setting, c):
    w = setting.omega_rad_s
    wt = w * t
    arg = wt + setting.alpha0_rad
    return (c.c1_m * np.exp(c.lambda1 * wt) + c.c2_m * np.exp(c.lambda2 * wt)
            + c.d_m * np.cos(arg) + c.m_m * np.sin(arg) + c.offset_m)


def slide_position(t, setting):
    """The straw's coordinate l(t) along the blade by the exact solution of eq. 1.

    Parameters
    ----------
    t : array_like
        Times since the impact, s (>= 0).
    setting : BladeSetting

    Returns
    -------
    ndarray
        l in m, same shape as ``t`` (valid while the straw is on the blade and moving
        outward, ``0 <= t <= t0``).
    """
    return _eval_eq2(_times(t), setting, slide_constants(setting))


def slide_speed(t, setting):
    """The straw's relative speed dl/dt along the blade (eq. 4, exact), m/s."""
    t = _times(t)
    c = slide_constants(setting)
    w = setting.omega_rad_s
    wt = w * t
    arg = wt + setting.alpha0_rad
    return w * (c.lambda1 * c.c1_m * np.exp(c.lambda1 * wt)
                + c.lambda2 * c.c2_m * np.exp(c.lambda2 * wt)
                - c.d_m * np.sin(arg) + c.m_m * np.cos(arg))


def slide_eq2_printed(t, setting):
    """Eq. 2 evaluated with the constants exactly as printed (see :func:`printed_constants`).

    Does not meet l(0) = l1; kept to show that error (``vidtrack bench model``).
    """
    return _eval_eq2(_times(t), setting, printed_constants(setting))


def initial_acceleration(setting):
    """``a0 = l''(0) = g cos(alpha0 - delta1 + phi)/cos(phi) + omega^2 (mu R sin delta1 + l1)``.

    The bracket of eqs. 3-5 and 8, m/s^2.
    """
    phi = setting.friction_angle_rad
    w = setting.omega_rad_s
    return (setting.g_m_s2 * math.cos(setting.alpha0_rad - setting.delta1_rad + phi)
            / math.cos(phi) + w * w * (setting.friction * setting.r0_m + setting.start_m))


def slide_eq3_series(t, setting):
    """Eq. 3, the paper's two-term series: ``l = l1 + a0 t^2 / 2``, m."""
    t = _times(t)
    return setting.start_m + 0.5 * initial_acceleration(setting) * t * t


def slide_eq4_series(t, setting):
    """Eq. 4 as printed (the derivative of eq. 3): ``v_r = a0 t``, m/s."""
    return initial_acceleration(setting) * _times(t)


def slide_ode(t, setting, *, method="DOP853", rtol=1e-12, atol=1e-15):
    """Eq. 1 integrated numerically with ``scipy.integrate.solve_ivp`` (a reference).

    The right-hand side is written from eq. 1 as printed (``rho cos delta = l``,
    ``rho sin delta = R sin delta1``, ``beta = alpha0 + omega t - delta1``), independent
    of the algebra of the closed form.

    Parameters
    ----------
    t : array_like, shape (N,)
        Times since the impact, s (>= 0), any order.
    setting : BladeSetting
    method, rtol, atol : keyword-only
        Passed to ``solve_ivp``.

    Returns
    -------
    ndarray, shape (N, 2)
        l in m and dl/dt in m/s.
    """
    from scipy.integrate import solve_ivp

    t = np.atleast_1d(_times(t))
    w = setting.omega_rad_s
    mu = setting.friction
    g = setting.g_m_s2
    r0 = setting.r0_m
    a0 = setting.alpha0_rad
    d1 = setting.delta1_rad

    def rhs(tt, y):
        l, v = y  # noqa: E741 (l is the paper's slide coordinate, eq. 1)
        beta = a0 + w * tt - d1
        # eq. 1: m l'' = m rho w^2 cos(delta) + m g cos(beta) - mu m g sin(beta)
        #                - mu (2 m w l' - m rho w^2 sin(delta))
        return [v, l * w * w + g * math.cos(beta) - mu * g * math.sin(beta)
                - mu * (2.0 * w * v - r0 * w * w)]

    order = np.argsort(t)
    ts = t[order]
    t_end = float(ts[-1]) if ts.size else 0.0
    out = np.empty((t.size, 2))
    if t_end == 0.0:
        out[:] = (setting.start_m, 0.0)
        return out
    sol = solve_ivp(rhs, (0.0, t_end), [setting.start_m, 0.0], method=method,
                    rtol=rtol, atol=atol, t_eval=ts)
    if not sol.success:  # pragma: no cover - solve_ivp on a smooth linear ODE
        raise InputError(f"solve_ivp failed on eq. 1: {sol.message}")
    out[order] = sol.y.T
    return out


# ---------------------------------------------------------------- the throwing conditions

def omega_min(setting):
    """Eq. 6: ``omega_min = sqrt(g / ((mu R sin delta1 + l1) cos phi))``, rad/s.

    ``nan`` when ``mu R sin delta1 + l1 <= 0`` (eq. 7 fails: no speed throws the straw).
    """
    shift = setting.friction * setting.r0_m + setting.start_m
    if shift <= 0:
        return math.nan
    return math.sqrt(setting.g_m_s2 / (shift * math.cos(setting.friction_angle_rad)))


@dataclass(frozen=True)
class ThrowCondition:
    """One throwing condition: its name (with the paper's equation), whether it holds,
    the value tested against the limit, and a sentence saying so."""

    name: str
    holds: bool
    value: float
    limit: float
    unit: str
    message: str

    def to_dict(self):
        """Plain JSON-ready values (``nan`` as ``None``)."""
        return {"name": self.name, "holds": self.holds, "value": _json_float(self.value),
                "limit": _json_float(self.limit), "unit": self.unit,
                "message": self.message}


def _json_float(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def throwing_conditions(setting):
    """The paper's throwing conditions, eqs. 5, 6 and 7, for ``setting``.

    Returns
    -------
    tuple of ThrowCondition
        ``eq. 5`` (a0 > 0: the straw starts outward at this phase), ``eq. 6``
        (omega > omega_min: outward at any phase), ``eq. 7`` (mu R sin(delta1) + l1 > 0,
        i.e. |delta1| < asin(l1 / (mu R)) for a forward-raked blade).
    """
    s = setting
    a0 = initial_acceleration(s)
    c5 = ThrowCondition(
        "eq. 5", a0 > 0, a0, 0.0, "m/s^2",
        f"eq. 5 {'holds' if a0 > 0 else 'fails'}: the straw's initial acceleration "
        f"along the blade is a0 = {a0:.4g} m/s^2 (must be > 0 for it to move outward)")
    w = s.omega_rad_s
    wmin = omega_min(s)
    holds6 = bool(math.isfinite(wmin) and w > wmin)
    if math.isfinite(wmin):
        n_min = wmin * 30.0 / math.pi
        msg6 = (f"eq. 6 {'holds' if holds6 else 'fails'}: the blade turns at omega = "
                f"{w:.4g} rad/s (n = {s.n_rpm:.4g} r/min); omega_min = {wmin:.4g} rad/s "
                f"(n > {n_min:.4g} r/min needed)")
    else:
        msg6 = ("eq. 6 fails: omega_min does not exist because "
                "mu R sin(delta1) + l1 <= 0 (see eq. 7)")
    c6 = ThrowCondition("eq. 6", holds6, w, wmin, "rad/s", msg6)
    shift = s.friction * s.r0_m + s.start_m
    holds7 = shift > 0
    if s.friction * s.radius_m > 0 and s.start_m / (s.friction * s.radius_m) < 1:
        limit7 = math.degrees(math.asin(max(-1.0, s.start_m / (s.friction * s.radius_m))))
        lim_txt = f"|delta1| < asin(l1 / (mu R)) = {limit7:.4g} deg for a forward rake"
    else:
        limit7 = 90.0
        lim_txt = "any rake angle (l1 >= mu R)"
    c7 = ThrowCondition(
        "eq. 7", holds7, s.blade_angle_deg, limit7, "deg",
        f"eq. 7 {'holds' if holds7 else 'fails'}: mu R sin(delta1) + l1 = {shift:.4g} m "
        f"(must be > 0: {lim_txt}; delta1 = {s.blade_angle_deg:.4g} deg)")
    return (c5, c6, c7)


# ---------------------------------------------------------------- release

@dataclass(frozen=True)
class Release:
    """The straw at the moment it leaves the blade tip (Chen 2018, eqs. 4, 8, 9, 10).

    Angles in rad, speeds in m/s, positions in m in the world frame (origin at
    the blade shaft, x outward, y up). Fields are ``nan`` when the straw never reaches
    the tip; ``thrown`` is False then, and ``violations`` says why.

    Attributes
    ----------
    setting : BladeSetting
    method : str
        ``"exact"`` (the exact solution of eq. 1) or ``"series"`` (eqs. 3, 4, 8 as the
        paper evaluates them).
    release_time_s : float
        t0, time from the impact to the release.
    rotation_rad : float
        The throw angle phi_throw = omega t0 (the paper's 抛出角).
    relative_speed_m_s, transport_speed_m_s, absolute_speed_m_s : float
        v_r (eq. 4), v_e = omega R, v_a (eq. 9).
    release_angle_rad : float
        theta, the angle of the absolute velocity with +X (eq. 10).
    x0_m, y0_m : float
        The release point (the tip).
    vx0_m_s, vy0_m_s, vz0_m_s : float
        Eq. 10; vz0 = v1 / 3.6 is the straw's absolute forward speed.
    min_normal_accel_m_s2 : float
        The smallest N/m over the slide (N the blade's normal force in eq. 1). Negative
        means eq. 1's friction term pushes the straw outward there, i.e. the straw
        would in fact lift off the blade face; the paper's model ignores this and so do
        we, but it is reported.
    conditions : tuple of ThrowCondition
        Eqs. 5, 6, 7 and "eq. 8 (exact)" (the slide reaches the tip).
    """

    setting: BladeSetting
    method: str
    release_time_s: float
    rotation_rad: float
    relative_speed_m_s: float
    transport_speed_m_s: float
    absolute_speed_m_s: float
    release_angle_rad: float
    x0_m: float
    y0_m: float
    vx0_m_s: float
    vy0_m_s: float
    vz0_m_s: float
    min_normal_accel_m_s2: float
    conditions: tuple = field(default_factory=tuple)

    def __repr__(self):
        s = self.setting
        if not self.thrown:
            why = ", ".join(c.name for c in self.violations)
            return (f"Release(n_rpm={s.n_rpm:g}, blade_angle_deg={s.blade_angle_deg:g}, "
                    f"method={self.method!r}, thrown=False: {why} fail)")
        return (f"Release(n_rpm={s.n_rpm:g}, blade_angle_deg={s.blade_angle_deg:g}, "
                f"method={self.method!r}, release_time_s={self.release_time_s:.4g}, "
                f"absolute_speed_m_s={self.absolute_speed_m_s:.4g}, "
                f"release_angle_deg={math.degrees(self.release_angle_rad):.4g})")

    @property
    def thrown(self):
        """True when every throwing condition holds."""
        return all(c.holds for c in self.conditions)

    @property
    def violations(self):
        """The conditions that fail, in the paper's order."""
        return tuple(c for c in self.conditions if not c.holds)

    def require_thrown(self):
        """Return self, or raise ``InputError`` naming every condition that fails.

        Raises
        ------
        fits.errors.InputError
            "the straw is not thrown at n = ... : eq. 6 fails: ..."
        """
        bad = self.violations
        if bad:
            s = self.setting
            raise InputError(
                f"the straw is not thrown at n = {s.n_rpm:g} r/min, delta1 = "
                f"{s.blade_angle_deg:g} deg (R = {s.radius_m:g} m, l1 = {s.start_m:g} m, "
                f"mu = {s.friction:g}, alpha0 = {s.phase_deg:g} deg): "
                + "; ".join(c.message for c in bad))
        return self

    def state(self):
        """``(x0, y0, z0, vx0, vy0, vz0)`` for ``fits.throw.position`` (z0 = 0)."""
        return (self.x0_m, self.y0_m, 0.0, self.vx0_m_s, self.vy0_m_s, self.vz0_m_s)

    def to_dict(self):
        """Plain JSON-ready values (``nan`` as ``None``); angles also in degrees."""
        f = _json_float
        return {
            "method": self.method,
            "setting": self.setting.to_dict(),
            "thrown": self.thrown,
            "release_time_s": f(self.release_time_s),
            "rotation_rad": f(self.rotation_rad),
            "rotation_deg": f(math.degrees(self.rotation_rad)),
            "relative_speed_m_s": f(self.relative_speed_m_s),
            "transport_speed_m_s": f(self.transport_speed_m_s),
            "absolute_speed_m_s": f(self.absolute_speed_m_s),
            "release_angle_rad": f(self.release_angle_rad),
            "release_angle_deg": f(math.degrees(self.release_angle_rad)),
            "x0_m": f(self.x0_m), "y0_m": f(self.y0_m), "z0_m": 0.0,
            "vx0_m_s": f(self.vx0_m_s), "vy0_m_s": f(self.vy0_m_s),
            "vz0_m_s": f(self.vz0_m_s),
            "min_normal_accel_m_s2": f(self.min_normal_accel_m_s2),
            "conditions": [c.to_dict() for c in self.conditions],
        }


def _first_root(func, grid, values):
    """The first sign change of ``values`` (func on ``grid``) from negative to >= 0."""
    from scipy.optimize import brentq

    idx = np.flatnonzero((values[:-1] < 0) & (values[1:] >= 0))
    if idx.size == 0:
        return math.nan
    i = int(idx[0])
    if values[i + 1] == 0:
        return float(grid[i + 1])
    return float(brentq(func, grid[i], grid[i + 1], xtol=1e-16, rtol=4 * np.finfo(float).eps,
                        maxiter=200))


def _exact_release_time(s):
    """(t0, t_stop): first tip crossing and first stop (l' = 0) of the exact slide."""
    w = s.omega_rad_s
    t_max = MAX_REVOLUTIONS * 2.0 * math.pi / w
    grid = np.linspace(0.0, t_max, int(MAX_REVOLUTIONS * _GRID_PER_REVOLUTION) + 1)
    gap = slide_position(grid, s) - s.tip_m
    t0 = _first_root(lambda t: float(slide_position(t, s) - s.tip_m), grid, gap)
    speed = slide_speed(grid[1:], s)
    # a stop: l' goes from > 0 to <= 0 (or is <= 0 from the start, when a0 <= 0)
    if initial_acceleration(s) <= 0:
        t_stop = 0.0
    else:
        neg = -speed
        t_stop = _first_root(lambda t: -float(slide_speed(t, s)), grid[1:], neg)
    return t0, t_stop


def release(setting, *, method="exact", speed_kmh=0.0):
    """Where, when and how fast the straw leaves the blade (eqs. 4, 8, 9, 10).

    Parameters
    ----------
    setting : BladeSetting
    method : {"exact", "series"}, keyword-only
        ``"exact"``: t0 is the first root of ``l(t) = R cos(delta1)`` on the exact
        solution of eq. 1 (within ``MAX_REVOLUTIONS`` turns) and ``v_r = l'(t0)``.
        ``"series"``: the paper's eqs. 8 and 4 (``t0 = sqrt(2 (R cos delta1 - l1)/a0)``,
        ``v_r = a0 t0``), for comparison.
    speed_kmh : float, keyword-only
        Machine travel speed v1 in km/h; vz0 = v1 / 3.6 (eq. 10).

    Returns
    -------
    Release
        Carries the conditions; a setting that violates one is still returned (with
        ``thrown`` False); call ``.require_thrown()`` to turn that into an error.

    Raises
    ------
    fits.errors.InputError
        An unknown method or a non-finite speed.
    """
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    speed_kmh = _finite("speed_kmh", speed_kmh)
    s = setting
    w = s.omega_rad_s
    conditions = list(throwing_conditions(s))
    a0 = initial_acceleration(s)

    if method == "exact":
        t0, t_stop = _exact_release_time(s)
        stops_first = math.isfinite(t_stop) and (not math.isfinite(t0) or t_stop < t0)
        reached = math.isfinite(t0) and not stops_first
        if reached:
            msg = (f"eq. 8 (exact) holds: the exact slide reaches the tip "
                   f"l = R cos(delta1) = {s.tip_m:.4g} m at t0 = {1e3 * t0:.4g} ms")
        elif stops_first and t_stop == 0.0:
            msg = ("eq. 8 (exact) fails: on the exact slide the straw moves inward from "
                   "the start (a0 <= 0) and never reaches the tip")
        elif stops_first:
            msg = (f"eq. 8 (exact) fails: on the exact slide the straw stops moving "
                   f"outward at t = {1e3 * t_stop:.4g} ms, before reaching the tip")
        else:
            msg = (f"eq. 8 (exact) fails: the exact slide does not reach the tip within "
                   f"{MAX_REVOLUTIONS:g} revolutions")
        conditions.append(ThrowCondition("eq. 8 (exact)", reached,
                                         t0 if reached else math.nan, math.nan, "s", msg))
        if reached:
            vr = float(slide_speed(t0, s))
            grid = np.linspace(0.0, t0, 401)
            beta = s.alpha0_rad + w * grid - s.delta1_rad
            normal = (s.g_m_s2 * np.sin(beta) + 2.0 * w * slide_speed(grid, s)
                      - w * w * s.r0_m)
            n_min = float(np.min(normal))
    else:
        reached = a0 > 0
        t0 = math.sqrt(2.0 * (s.tip_m - s.start_m) / a0) if reached else math.nan
        vr = a0 * t0 if reached else math.nan
        msg = (f"eq. 8 (series) {'holds' if reached else 'fails'}: "
               + (f"t0 = {1e3 * t0:.4g} ms" if reached else "a0 <= 0, eq. 8 has no root"))
        conditions.append(ThrowCondition("eq. 8 (series)", reached, t0, math.nan, "s", msg))
        if reached:
            n_min = math.nan

    ve = w * s.radius_m
    vz0 = speed_kmh / 3.6
    if not reached:
        nan = math.nan
        return Release(s, method, nan, nan, nan, ve, nan, nan, nan, nan, nan, nan, vz0,
                       nan, tuple(conditions))
    d1 = s.delta1_rad
    va = math.sqrt(max(0.0, vr * vr + ve * ve - 2.0 * vr * ve * math.sin(d1)))
    rotation = w * t0
    tau = s.alpha0_rad + rotation                     # the tip velocity's angle with +X
    v_t = ve - vr * math.sin(d1)                      # along the tip velocity
    v_rad = vr * math.cos(d1)                         # along the outward radius
    theta = tau - math.atan2(v_rad, v_t)              # eq. 10
    return Release(
        setting=s, method=method, release_time_s=t0, rotation_rad=rotation,
        relative_speed_m_s=vr, transport_speed_m_s=ve, absolute_speed_m_s=va,
        release_angle_rad=theta,
        x0_m=s.radius_m * math.sin(tau), y0_m=-s.radius_m * math.cos(tau),
        vx0_m_s=va * math.cos(theta), vy0_m_s=va * math.sin(theta), vz0_m_s=vz0,
        min_normal_accel_m_s2=n_min, conditions=tuple(conditions))
