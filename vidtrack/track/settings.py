"""Every threshold of the flight tracker, with its unit and meaning, in one frozen object.

The flight tracker (:mod:`vidtrack.track.flight`) is one mechanism in five steps: detect
what differs from the background, link detections into tracklets, choose the chain of
detections a free flight explains, measure each frame, flag each frame by statistics.
Each step reads its thresholds from one :class:`TrackerSettings`; nothing is typed inline.
The settings and :data:`ALGORITHM_VERSION` together identify what computed a track: they
go into the run's stage cache key, so a track made by other code or other settings is
never reused.
"""

from dataclasses import asdict, dataclass, fields

from vidtrack.errors import VidtrackError

__all__ = ["TrackerSettings", "ALGORITHM_VERSION"]

#: Changes whenever the flight tracker's results may change for the same settings.
ALGORITHM_VERSION = "flight-24"


@dataclass(frozen=True)
class TrackerSettings:
    """The flight tracker's settings (every one named, with its unit).

    Attributes
    ----------
    k_sigma : float
        Detection threshold: a pixel is foreground where it differs from the background by
        more than ``k_sigma`` times its noise (noise units). 5 keeps false pixels to about
        one in 10^6 for Gaussian noise.
    k_grow : float
        Hysteresis: a detection is the connected pixels beyond ``k_grow`` times the noise
        round at least one beyond ``k_sigma`` (noise units), so a faint edge belongs to its
        object without lowering the seed threshold.
    min_area_px : int
        Smallest detection, in pixels beyond ``k_grow`` (px).
    min_snr : float
        Smallest signal-to-noise ratio of a detection: the sum of its pixels' differences
        from the background in noise units over the square root of their count. A
        compression speck (5 pixels about 3 noise units off) scores about 7; a ball 5 px
        across 25 grey levels darker, 50.
    background_samples : int
        Frames in the background's per-pixel median, spread over the whole footage.
    shadow_ratio_min : float
        The photometric shadow test: a detection all of whose pixels are darker than the
        background, by a factor no smaller than this (frame / background, 10th
        percentile), is shadow-like: a shadow dims the background, an object of its
        own grey level hides it. 0.5 takes a dimming to half as a shadow.
    shadow_texture_min : float
        Where the background has texture (its standard deviation over the detection, or
        over the 5 x 5 px square round a pixel, at least 3 times the noise), the
        detection, or the pixel, is a shadow's only when the frame's texture there
        correlates with the background's at least this much (Pearson r); the pixel's
        square, dimmed on average by no more than ``shadow_ratio_min``, is then no
        foreground.
    shadow_rim_px : float
        A dark object of one level darker than a shadow could make any of the wall round
        it: its pixels dimmed no more than ``shadow_ratio_min`` are its blurred rim within
        this distance (px) of those it dims more; farther, a lighter shadow of its
        polarity touching it, of no weight. Measured on a synthetic dark ball with its
        shadow touching it: 1 px, 0.29 px median from its centre (0.41 at most); 1.5 px,
        0.40 (0.55); 2 px, 0.59 (0.74); without, 3.0 (3.9). The scoreboard's dark straws:
        0.0248 -> 0.0259 px RMS (front), 0.0245 -> 0.0246 (top).
    gate_px : float
        Linking: smallest gate round a tracklet's predicted position (px).
    gate_sizes : float
        Linking and growing: the gate also spans this many object sizes (a size is the
        square root of the detection's area; dimensionless).
    max_step : float
        Fastest motion looked for, as a share of the frame's diagonal per frame: a new
        tracklet (speed unknown) takes its second detection within it.
    max_gap : int
        Frames a tracklet or a chain may go without a detection before it ends (frames).
    link_min_frames : int
        Shortest tracklet that seeds a chain (frames).
    predict_frames : int
        A chain's next position is extrapolated from a quadratic through its last this
        many points (frames).
    min_travel_sizes : float
        A chain is a flight only when it travels at least this many of its own sizes
        (dimensionless): something that rocks in place is not thrown.
    flight_residual_px : float
        Choosing: a frame counts towards a chain's flight when it lies within this
        distance (px) of the local quadratic path through its neighbours, or
        ``flight_residual_sizes`` of the object's size, the larger.
    flight_residual_sizes : float
        The same distance as a share of the object's size (square root of its pixel
        count): a large object's centroid wanders more as its shape turns (0.1 of a
        size is added to ``flight_model_px`` for the flight's cubic).
    flight_model_px : float
        Choosing: a chain's flight is the longest span round its middle that one cubic
        in time explains within this distance (px; 90th percentile) plus
        ``flight_residual_sizes`` of its size: free flight with a drag that changes
        smoothly (a straw's 0.3 s flight at 1200 fps: 0.23 px). A blade's tip going
        round (2.7 px over a turn), a hand turning back, is explained in part.
    ambiguity_ratio : float
        Two chains seen at the same time whose flight scores, and whose signals (summed
        weights), are within this ratio of each other (neither a shadow) are ambiguous:
        the tracker stops and names both, with the ``target`` line that picks one.
    seeds_max : int
        At most this many tracklets (the longest travellers) seed chains (count).
    kernel_sigmas : float
        Measuring: the object's elliptical kernel reaches this many of its spreads along
        each axis (dimensionless); pixels beyond it (something touching) have no weight.
        A rod's end lies at 1.73 spreads along it.
    residual_floor : float
        The smallest scatter of the residual share (the weight near the object outside
        its kernel over all of it) that the appearance test divides by.
    k_flag : float
        Flagging: a frame is an outlier when its distance from the local path of its
        neighbours exceeds ``k_flag`` times the chain's robust scatter of such distances, and
        unlike the object when its size differs from that of its neighbours by more than
        ``k_flag`` times their robust scatter of log size.
    flag_floor_px : float
        A frame nearer its neighbours' path than this (px) is never an outlier, however
        small the chain's scatter.
    size_floor : float
        The size test's smallest scatter of log area (dimensionless).
    weight_floor : float
        The smallest scatter of the log of the object's measured weight (its coverage)
        that the appearance test divides by: with ``k_flag`` 5, a frame with a tenth of
        the object hidden is flagged.
    footprint_floor : float
        The smallest scatter of a rod's misfit over its own footprint (its bar's RMS
        residual there over its coverage, its ends' caps apart) that the misfit test
        divides by: with ``k_flag`` 5, a frame 0.05 above the centre of the chain's clean
        side (:func:`vidtrack.track.path.clean_side`) is flagged (touched). Measured
        scatter: synthetic straws 0.006-0.014; a straw coming out from behind a post, 3 %
        of it hidden at an end, 0.11 over the median.
    width_floor : float
        The smallest scatter of the log of a rod's width (its diameter, whatever its
        attitude) that the width test divides by: with ``k_flag`` 5, a rod 5 % narrower
        (part of it hidden along its side) or wider (something alongside it) than the
        median of its neighbours over ``4 * path_window`` frames either side is flagged.
        Measured scatter of synthetic straws' widths: 0.002-0.005, 0.013 with a
        highlight.
    profile_floor : float
        The smallest scatter of the log of a rod's spread along it (its bar's length
        and blur along, against their robust trend over ``8 * path_window`` frames
        either side) that the profile test divides by: with ``k_flag`` 5, a bar 1 %
        longer than its trend is measured again with the rod's own length and blurs
        held (:func:`vidtrack.track.joined.hold_profile`). Measured scatter: synthetic
        straws 0.002; a dark straw's end touching the blade it has just left, in line
        with it, 1.3-2.7 % over its trend.
    path_window : int
        Frames either side of a frame in its local path fit (frames).
    release_window : int
        The release is looked for among the chain's first ``release_window`` clean
        frames (frames).
    release_significance : float
        A knot in the path's acceleration (:mod:`vidtrack.track.release`) counts when it
        lowers the residual sum of squares by more than this many noise variances.
    release_ratio : float
        ... and when the acceleration just before it is at least this many times that of
        the flight after it (the ride on a blade or in a hand is the strongly
        accelerated part; dimensionless).
    release_push_deg : float
        ... and when the ride's extra acceleration lies within this angle of the
        velocity at the knot (degrees, at most 180): a blade or a hand pushes (near 0)
        or turns (near 90) what it carries, seen touching it or not (a straw on a blade
        hides the blade under it), while drag falling off as a light object slows down,
        or a shuttlecock's after a racket's hit, leaves a braking before the knot (near
        180).
    highlight_one_side : float
        A detection of two polarities has a body (the polarity most of its pixels beyond
        ``k_grow`` show) whose level is kept where it lies on one side of the background
        under at least this share of its pixels; else (a grey object over a light wall
        and a dark floor) it is of several tones.
    highlight_frames : float
        A chain's object is a body with a highlight where at least this share of its
        frames show such a body (measured: the synthetic dark straws and balls with a
        highlight 0.98-1, the bears 0.47 and 0.21, the diabolo's white and grey cup 0.19,
        the launcher 0.08): its pixels are read against the body's level and its
        highlight covers. Else its frames of two polarities are all weighed by their
        bounded difference, alike (one model for all its frames keeps its points
        consistent).
    highlight_core : float
        A body's core is the pixels it covers at least this share of (a dimmer object of
        its polarity beside it, a rider of half its contrast, is not in it): its
        highlight, and the pixels beside it where the two cancel, cover fully inside the
        core's convex hull.
    highlight_enclosed : float
        A detection's pixels brighter than the background are a highlight on its darker
        pixels where at least this share of the ring round them is the darker part (a
        highlight lies inside its body); less, and its darker pixels all dimmed by a
        shadow's factor (``shadow_ratio_min``), it is a bright object beside its shadow,
        measured without it.
    model_max_misfit : float
        A compact object is measured by the ellipse fitted to it only where the ellipse
        explains it: its RMS residual over the best-explained 90 % of its footprint
        (``vidtrack.track.ellipse.EXPLAINED_SHARE``) at most this share of its
        coverage (the synthetic balls 0.02-0.05, a dark ball with a highlight 0.06; a
        shuttlecock 0.14, a bear 0.5-1).
    bar_cap_px : float
        A rod's misfit is also taken over the caps beyond its bar's ends, this far along
        (px) and as wide as the bar: something in line with an end (the blade it has
        left) moves the end, and the centre along, where something beside it does not.
    camera_agree_share : float
        A shaking camera (:mod:`vidtrack.track.steady`): each of 16 cells of the frame
        votes with its corners' median shift, and a frame's shift is the one the most
        cells agree with (within half a pixel), where they are at least this share of
        the cells voting and outnumber any other group agreeing among itself (a person,
        the turning rotor). At a half, a 320 x 96 px top view, the rotor in four of its
        nine voting cells, lost 45 of 372 frames' shifts (0.16 px RMS from the camera's
        motion); at a third, none (0.07 px).
    joined_cover : float
        A rod followed by its model into what it is joined to before its flight (a
        straw riding a blade, :mod:`vidtrack.track.joined`) is seen in a frame only where
        the bar fitted there covers at least this share of the flight's coverage
        (a share): less, it is hidden behind what it rides, or gone.
    stood_share : float
        The background without the object (:func:`vidtrack.track.background.without_object`):
        a pixel the chosen object covers in at least this share of the background's
        samples (a ball held still, lying where it landed; the median is the object's
        where it stood in half of them) gets the median of the samples that show it
        without the object (a share).
    stood_reach : float
        Where the object lies in a sample: a disc round its chain's position of this many
        times its half extent (twice its spread along its major axis), plus a pixel;
        twice as wide before its chain's first frame and after its last (dimensionless).
    stood_moved_share : float
        The view is tracked again against that background where the pixels it changes by
        more than ``k_grow`` noises make up at least this share of the object's area (a
        share).
    rest_frames : int
        The object at rest before it moves (held, lying on a blade) is not in flight:
        at least this many frames at the start of its chain within ``rest_px`` (or
        ``rest_scatters`` scatters) of where they start, with no drift across them, are
        PRE_RELEASE (frames).
    rest_px : float
        ... their smallest tolerance (px).
    rest_scatters : float
        ... and their tolerance in the chain's robust scatters about its path (noise
        units); their straight line in time must move less than half the tolerance.
    matte_misfit_max : float
        A compact object is measured by its matte (:mod:`vidtrack.track.matte`) only
        where the matte explains its frames at its own shifts to within this many
        pixel noises (the median RMS residual over the object's region): the synthetic
        textured toys 0.97-1.02; a tumbling 4 px object 3.2, balls whose shadow moves
        under them 2.7-2.9 (noise units).
    matte_gain_min : float
        ... and where it explains them at least this many times better (the median ratio
        of RMS residuals over the object's region) at its own shifts than at the
        outline's points: the textured toys 2.2-4.1 (the matte within 0.25 px of their
        centres, the outline 0.8-6.7 px off); balls 0.98-1.03 and every real clip
        1.01-1.04, where the outline is as near the truth or nearer.
    """

    k_sigma: float = 5.0
    k_grow: float = 4.0
    min_area_px: int = 4
    min_snr: float = 12.0
    background_samples: int = 25
    shadow_ratio_min: float = 0.5
    shadow_texture_min: float = 0.6
    shadow_rim_px: float = 1.0
    gate_px: float = 6.0
    gate_sizes: float = 1.5
    max_step: float = 0.15
    max_gap: int = 5
    link_min_frames: int = 4
    predict_frames: int = 8
    min_travel_sizes: float = 2.0
    flight_residual_px: float = 1.5
    flight_residual_sizes: float = 0.1
    flight_model_px: float = 1.0
    ambiguity_ratio: float = 1.25
    seeds_max: int = 12
    kernel_sigmas: float = 2.5
    residual_floor: float = 0.02
    k_flag: float = 5.0
    flag_floor_px: float = 0.5
    size_floor: float = 0.08
    weight_floor: float = 0.02
    width_floor: float = 0.01
    profile_floor: float = 0.002
    footprint_floor: float = 0.01
    path_window: int = 6
    release_window: int = 80
    release_significance: float = 25.0
    release_ratio: float = 2.0
    release_push_deg: float = 120.0
    highlight_one_side: float = 0.9
    highlight_frames: float = 0.5
    highlight_core: float = 0.75
    highlight_enclosed: float = 0.5
    model_max_misfit: float = 0.12
    bar_cap_px: float = 2.0
    camera_agree_share: float = 1.0 / 3.0
    joined_cover: float = 0.5
    stood_share: float = 0.25
    stood_reach: float = 1.5
    stood_moved_share: float = 0.25
    rest_frames: int = 5
    rest_px: float = 0.25
    rest_scatters: float = 4.0
    matte_misfit_max: float = 1.5
    matte_gain_min: float = 1.5

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            kind = int if f.type in ("int", int) else float
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise VidtrackError(f"track.{f.name} must be a number, got {value!r}")
            if kind is int and int(value) != value:
                raise VidtrackError(f"track.{f.name} must be a whole number, got {value!r}")
            if not value > 0 or value != value or value == float("inf"):
                raise VidtrackError(f"track.{f.name} must be a finite number > 0, got {value!r}")
        if self.k_grow > self.k_sigma:
            raise VidtrackError(f"track.k_grow must be at most track.k_sigma "
                                f"({self.k_sigma:g}), got {self.k_grow:g}")
        if self.release_push_deg > 180.0:
            raise VidtrackError(f"track.release_push_deg must be at most 180 (degrees), got "
                                f"{self.release_push_deg:g}")
        for name in ("highlight_one_side", "highlight_frames", "highlight_core",
                     "highlight_enclosed",
                     "camera_agree_share", "joined_cover", "stood_share"):
            if getattr(self, name) > 1.0:
                raise VidtrackError(f"track.{name} must be at most 1 (a share), got "
                                    f"{getattr(self, name):g}")
        if self.shadow_ratio_min >= 1.0 or self.shadow_texture_min >= 1.0:
            raise VidtrackError("track.shadow_ratio_min and track.shadow_texture_min must be "
                                "below 1")

    @classmethod
    def from_mapping(cls, mapping, *, where="track"):
        """Settings from a ``[track]`` table; an unknown name is refused, naming it."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(mapping) - known)
        if unknown:
            raise VidtrackError(f"{where}.{unknown[0]} is not a setting of the flight tracker; "
                                f"expected one of engine, {', '.join(sorted(known))}")
        return cls(**dict(mapping))

    def to_dict(self):
        """The settings as JSON-ready values (for the cache key and the notes)."""
        return asdict(self)
