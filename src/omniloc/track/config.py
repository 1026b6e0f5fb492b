"""The tracker's settings: :class:`TrackerConfig`, every value with its unit, and the checks
that refuse a setting the tracker cannot work with (by name, before any frame).

The settings' meaning is in :class:`TrackerConfig`'s docstring; the tracker that reads them
is :mod:`omniloc.track.tracker`, and :func:`omniloc.track.preset` gives the configurations
fitted to a robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from ..errors import InputError
from ..io import finite_number, shorten
from .confidence import RECENT_S, confidence_table

__all__ = ["TrackerConfig"]

_INTS = {
    "min_confirmations",
    "keep_after",
    "max_hypotheses",
    "search_min_bearings",
    "search_max_bearings",
    "search_max_spurious",
    "search_max_nodes",
    "max_candidates",
    "max_reported",
    "elsewhere_samples",
}
_PROBABILITIES = {
    "localized_probability",
    "kidnap_share",
    "lost_share",
    "prune_weight",
    "elsewhere_inject",
}
#: Probabilities that may be None (off).
_OPTIONAL_PROBABILITIES = {"search_miss", "keep_probability", "model_check"}
#: Angles (rad) of the configuration that a heading or bearing error is compared with or
#: spread by: beyond a half turn they take every error, a sure sign of degrees.
_HALF_TURN_ANGLES = (
    "tolerance_heading",
    "merge_heading",
    "candidate_min_sd_heading",
    "clutter_persistence_sd",
    "core_sigma",
)
_SHARES = {"fit_explained", "core_share", "miss_weight", "kidnap_fit"}
_BOOLS = {
    "core_update",
    "temper_update",
    "nonempty_frames",
    "exclusive_landmarks",
    "entry_replay",
    "pair_search",
}
#: The confidence tables (:mod:`omniloc.track.confidence`).
_CONFIDENCE_TABLES = (
    "confidence_localized",
    "confidence_ambiguous",
    "confidence_recent",
    "confidence_hypothesis",
    "confidence_hypothesis_recent",
    "confidence_backward",
)
#: Largest accepted value of a real-valued setting (seconds, metres, radians, rates): beyond
#: it products and squares in the filter would overflow long before anything useful happens.
VALUE_MAX = 1e6
#: Largest accepted count, and tighter bounds where a count is an allocation made up front
#: or every frame (elsewhere's particles are all weighed at every frame).
INT_MAX = 10**9
_INT_MAX = {"elsewhere_samples": 100_000, "max_hypotheses": 10_000, "max_candidates": 1_000_000}

#: Largest ``min_landmarks``: the landmarks named by some seconds of frames of a few bearings
#: each; a thousand or more is a typo.
MIN_LANDMARKS_MAX = 1000
#: Largest ``keep_unexplained``: a frame holds at most ``tracker.MAX_FRAME_BEARINGS`` (1,000).
KEEP_UNEXPLAINED_MAX = 1000
#: The settings that count (0: no such test) and their largest values.
_COUNTS = {
    "min_landmarks": MIN_LANDMARKS_MAX,
    "keep_unexplained": KEEP_UNEXPLAINED_MAX,
    "min_confirmations_alone": INT_MAX,
}

#: Largest seed of elsewhere's random generator.
SEED_MAX = 2**63 - 1


@dataclass(frozen=True)
class TrackerConfig:
    """How the tracker decides (every value has a unit; :func:`~omniloc.track.preset` gives
    tuned sets). Every value is checked when the configuration is made: real values finite,
    >= 0 and at most :data:`VALUE_MAX`, counts whole and at most :data:`INT_MAX`
    (``elsewhere_samples`` at most 100,000, ``max_hypotheses`` 10,000, ``max_candidates``
    1,000,000), the angles a heading or bearing error is compared with or spread by
    (``tolerance_heading``, ``merge_heading``, ``candidate_min_sd_heading``,
    ``clutter_persistence_sd``, ``core_sigma``) at most a half turn, pi (more is degrees
    passed as radians); an ``InputError`` names the field.

    Parameters
    ----------
    localized_probability : float
        ``localized`` needs at least this probability that the reported pose is within
        ``tolerance_m`` and ``tolerance_heading`` of the truth.
    tolerance_m : float
        Position tolerance of that statement, metres.
    tolerance_heading : float
        Heading tolerance of that statement, radians.
    keep_probability : float or None
        Once ``localized`` (by every test above, ``localized_probability`` included) for
        ``keep_after`` frames in a row, the tracker stays ``localized`` at that place while
        the place still holds ``localized_probability`` of the mass and its covariance puts
        it within tolerance with at least this probability (a hysteresis on the pose's
        uncertainty only: the frames with few landmarks, over which the odometry's error
        grows, no longer break the track; a rival or elsewhere taking mass still does).
        None (the default): no hysteresis. The reason of a frame kept so begins "kept:".
        At most ``localized_probability``. Kept frames do not restart ``kidnap_watch_s``.
    keep_after : int
        Frames ``localized`` in a row (by the full tests) before ``keep_probability``
        applies: a place the weights are sure of for a frame or two is not kept.
    keep_unexplained : int
        A frame of at least this many bearings of which the place explains none (each
        within the sensor's gate of a landmark in view, as ``min_landmarks`` counts them)
        is not kept by ``keep_probability`` (0, the default: no such test). The first frame
        after a kidnapping is most often of this kind; a frame of a right place seldom is.
    lost_share : float
        ``lost`` when elsewhere holds at least this share of the mass (or there is no
        hypothesis).
    kidnap_rate : float
        Prior rate (per second) of being carried off: between frames this share per second
        of the hypotheses' mass moves to elsewhere.
    evidence_weight : float
        Factor on every frame's log-likelihood ratio (1: Bayes' rule; below 1 when frames
        from nearly one pose repeat their errors and should count less).
    region : tuple of 4 floats or None
        ``(xmin, xmax, ymin, ymax)``, metres: where the robot may be (the prior of elsewhere
        and of new hypotheses). None: the landmarks' bounding box widened by
        ``region_margin_m``.
    region_margin_m : float
        See ``region``.
    elsewhere_samples : int
        Particles that carry elsewhere (:mod:`.elsewhere`).
    elsewhere_inject : float
        Share of them drawn afresh from the region at each resampling.
    min_confirmations : int
        ``localized`` needs the best place to have been found by this many searches on
        frames that do not overlap (track confirmation: one window of a few bearings on a
        map of clusters can be explained by a wrong pose; several seldom are, by the same
        one).
    min_confirmations_alone : int
        The searches asked instead of ``min_confirmations`` of a place no rival contests:
        every hypothesis tracked is at that place (the look-alikes the searches found have
        all been pruned by the evidence). 0: ``min_confirmations`` for every place. The
        second search is there to rule out a look-alike; where the frames name too few
        distinct landmarks for any search to run (``search_min_bearings``), a place alone
        would otherwise wait for frames that tell nothing new.
    min_age_s : float
        A hypothesis must have been tracked this long (s) before its place can be
        localized (a new one has been weighed only on its replay).
    min_best_s : float
        ``localized`` (by the full tests) needs the best place to have been the best for
        this long (s), frame after frame (0: no such test). ``min_age_s`` counts from when a
        place was found, and a place is often found long before it leads: a rival tracked
        for tens of seconds at a few per cent that takes the mass in one frame of many
        bearings would otherwise be called localized in that frame. The place is the same
        from one frame to the next when the last frame's best hypothesis, carried by the
        odometry, lies within the tolerances of this frame's (whatever merges and splits
        did to the hypotheses); another place leading for one frame starts the count again.
        A pose told as surely as ``localized`` asks (:meth:`Tracker.set_pose`) has led since
        it was told.
    min_landmarks : int
        ``localized`` (by the full tests, not the hysteresis of ``keep_probability``) needs
        the bearings of the last ``landmarks_window_s`` seconds to be explained, from the
        best place carried back along the odometry, by at least this many distinct
        landmarks (each bearing by the nearest landmark in view within the sensor's gate,
        widened by the place's heading variance). Three landmarks fix a pose from bearings
        and a fourth checks it (the interpretation tree's test at depth > 3): a place that
        takes one moving object for a landmark frame after frame explains its bearings as
        well as the truth does. 0: no such test; more than the map's landmarks is refused
        when the tracker is built. It checks something only where the landmarks in view are
        sparser than the gate (among thousands in view any bearing names one), and it costs
        the window's frames times the landmarks within reach at each decision that gets
        that far (on MRCLAM about 0.5 ms, 802 of robot 3's frames; 3 ms on 10,000 landmarks
        with an 8 m range, 0.12 s without a range): give a large map's sensor a range.
    landmarks_window_s : float
        The seconds of frames ``min_landmarks`` counts over.
    search_window_s : float
        Frames of the last this many seconds are stacked for a search.
    search_interval_s : float
        At most one search per this many seconds.
    search_min_bearings : int
        A search needs at least this many stacked (merged) bearings.
    search_max_bearings : int
        At most this many stacked bearings go into a search.
    search_max_spurious : int
        Bearings a search may leave unmatched.
    search_max_nodes : int
        Work budget of one search (nodes of the interpretation tree). It decides where a
        search stops, so that a run gives the same states on any machine and under any load
        (the largest search on the MRCLAM runs visits about 40,000 nodes). Pieces of a
        search that run side by side may together spend up to twice it (see
        :class:`~omniloc.Budget`).
    search_timeout_s : float
        Time budget of one search: a safety net above the node budget (at the usual 60,000
        to 80,000 nodes per second, the node budget is reached first).
    near_range_m : float
        Range at which the travel over the search window is turned into bearing noise.
    candidate_cov_inflation : float
        Factor on a search solution's covariance before its replay.
    candidate_min_sd_m, candidate_min_sd_heading : float
        ... and the least standard deviations it starts the replay with (m, rad).
    fit_window_s : float
        Time constant (s) of the counts of bearings a hypothesis explained recently.
    fit_explained : float
        ``localized`` needs the best hypothesis to explain at least this share of the
        recent bearings (a wrong pose can hold the mass by explaining a few and calling the
        rest clutter when the rivals explain fewer).
    model_check : float or None
        ``localized`` (by the full tests) needs the best place's recent frames to fit the
        sensor model, each test at this level (a p-value): the landmarks plainly in view
        from the place (a gate's width inside the view's edges, 5 % inside the range's) seen
        no less often than the sensor's ``p_detect`` allows (binomial), and the bearings
        that no landmark in view explains no more numerous than its clutter rate allows
        (Poisson). The weights only compare the places the tracker holds: when the true
        place is in none of them (a search that missed it, a look-alike left after a
        kidnapping) the best of them can hold all the mass, and it is seen through by what
        it predicts and the camera does not see. None: no such test (the ``mrclam``
        preset, whose sensor model is the recordings' average, not a frame's). Each count
        is tested only if the sensor states its rate (``SensorModel.p_detect``,
        ``clutter``; the frame model's defaults for an unstated one are a guess). A sensor
        whose stated rates or range are too optimistic makes the test hold true places back
        too; the reason says which count failed.
    model_check_s : float
        The seconds of frames (since the place was found, at most this many) that
        ``model_check`` tests; the newest frame is also tested alone, at the same level (a
        frame after a kidnapping whose bearings the old place leaves unexplained, or whose
        landmarks it predicts and the camera does not report, would drown in the window's
        rates: on the simulated look-alikes, 105 wrong frames became 84, the frames at the
        jumps 35 -> 15, for 7 of 27,214 right ones; since 2026-12-07).
    clutter_persistence : float
        Clutter with memory (0, the default: none). The chance that a bearing a place
        explains as clutter -- another robot, say -- is seen again in the next frame with
        bearings (within ``clutter_memory_s``), within ``clutter_persistence_sd`` of where the
        odometry's turn puts it; the rest of the measured clutter rate (a share
        ``1 - clutter_persistence``) is new clutter. Without it, a wrong place that explains
        a persistent object as a landmark earns a few nats from it in every frame.
    clutter_persistence_sd : float
        Spread of such an object's bearing from one frame to the next, radians.
    clutter_memory_s : float
        An object not seen again within this many seconds is forgotten.
    split_clutter : float
        0 (the default): each hypothesis takes a frame as one mixture of its readings
        (probabilistic data association, collapsed to one Gaussian). Above 0: when the
        posterior probability that every bearing of the frame is clutter lies between this
        and 1 minus this, the hypothesis splits in two -- one that took the bearings as
        landmarks, one that took them all as clutter and did not move -- each with its share
        of the mass (a vague heading otherwise lets another robot's bearing pull the pose to
        the tube beside it, and the collapsed hypothesis cannot come back).
    turn_noise_s : float
        Bearing noise that grows with the turn rate: a frame taken while the robot turns at
        ``w`` rad/s has a bearing variance of ``sigma^2 + (w * turn_noise_s)^2`` (the
        image's exposure and time stamp are not one instant). MRCLAM: bearing errors with a
        robust sd of 0.41 deg standing still, 1.3 deg turning at 0.3-0.6 rad/s. 0 (default):
        off.
    core_share, core_sigma : float
        Bearing errors with a sharp core and a heavier tail: a share ``core_share`` of the
        bearings has the error sd ``core_sigma`` (radians), the rest the sensor's sigma
        (the mixture of two Gaussians, in every hypothesis, replay and particle). MRCLAM's
        errors at the true poses fit 57 % at 0.33 deg and 43 % at 1.03 deg (15,000
        bearings, two components by EM; ``omniloc fit-sensor`` fits them). 0 (default): the
        sensor's sigma alone.
    core_update : bool
        With a sharp core: whether its reading also moves each hypothesis by its own, sharper
        Kalman gain (True, the default: the mixture in the update as in the weights) or only
        weighs the hypotheses, the update taking both readings of a landmark together with
        the tail's variance (False: the hypotheses' covariances shrink no faster than with
        the sensor's sigma alone). MRCLAM's bearing errors repeat from frame to frame, and a
        sharp update there leaves covariances too small (docs/tracking.md).
    temper_update : bool
        Whether the Kalman update is tempered like the weights: with ``evidence_weight``
        ``w`` below 1 each frame's likelihood counts as its ``w``-th power in the weights,
        which for a Gaussian bearing is the variance ``sigma^2 / w``; True updates the pose
        and covariance with that variance too, so that a hypothesis's covariance is the one
        of the tempered model it is weighed by (``evidence_weight`` then at least 1e-6).
        False (default): the update uses ``sigma^2`` (the covariance shrinks as if every
        frame were independent).
    nonempty_frames : bool
        Whether the frames come from a log that lists only frames with a bearing (MRCLAM:
        its measurements are logged per detection, and 46 % of the camera's frames, those
        that saw nothing, are not in it). True weighs each frame with bearings by its
        likelihood given that it holds one, ``p(z | pose) / P(some bearing | pose)``: a pose
        that expects several landmarks in view is not credited for the frames in which it
        would have seen none, since those were never recorded. The sensor's ``p_detect`` and
        ``clutter`` are then the rates over every camera frame, empty ones included. False
        (default): every frame the camera took is in the input, empty ones too.
    miss_weight : float
        Weight (0 to 1) of the landmarks in view that a frame did not report, in the
        weights: each costs ``miss_weight * ln(1 - d)`` instead of ``ln(1 - d)`` (on top of
        ``evidence_weight``). For a camera whose detections come in bursts: MRCLAM's count
        of reported tubes has 2.6 times the variance of independent detections, and a run
        of frames that report one of five tubes in view (robot 5 at 622-635 s) cost the true
        place a nat a frame until elsewhere took it. 1 (default): every miss counts in full.
    exclusive_landmarks : bool
        A landmark explains at most one bearing of a frame: a frame is weighed by the sum
        over the assignments in which no landmark takes two bearings (exactly, over the
        landmarks that two bearings read; :mod:`omniloc.track.likelihood`). On a map of
        clusters, a place turned against the truth can otherwise explain two bearings of
        one frame by one landmark near both. The updates of the poses are as without it.
        Its cost grows as 2^k with the k bearings of a frame that contest a landmark (a few
        on MRCLAM); beyond 12 such bearings a frame is weighed as without it.
        False (default): each bearing is weighed on its own (one landmark read by two
        bearings of a frame costs nothing).
    occlusion_width : float
        Metres: landmarks hide the ones behind them. A landmark's chance of being reported
        is multiplied, for each nearer landmark, by ``1 - exp(-l^2 / (2 w^2))``, ``l`` being
        how far the line of sight to it passes beside the nearer one. Roughly the radius of
        a landmark plus what the detector needs to tell two apart: on MRCLAM a tube whose
        line of sight passes within 1 cm of a nearer tube was reported in none of 321
        sightings, within 3-4 cm a third as often as one with no tube near its line of
        sight, within 5-6 cm 64 % as often; 0.04 m fits best
        (``benchmarks/detection_occlusion.py``), with a ``p_detect`` 5 % higher than
        without. It sharpens the posterior: on MRCLAM the true place kept its mass longer
        and wrong places were localized more often (docs/tracking.md, item 16). 0
        (default): no landmark hides another.
    covariance_inflation : float
        Factor (>= 1) on the covariances the tracker reports and decides ``localized`` by (the
        probability of being within the tolerances), not on its filters' own: for data
        where the filters' covariances are too small (MRCLAM: the truth inside the 50 %
        region in 40 % of the localized frames). 1 (default): as the filters have them.
    search_miss : float or None
        None (the default): Bayes' rule -- elsewhere earns each frame's likelihood ratio
        averaged over its particles, like any hypothesis. A probability: the chance that a
        search misses the true pose, for maps and sensors where the searches often do (a
        narrow camera on a map of near-symmetric clusters): between searches elsewhere then
        explains each frame at least as well as the best hypothesis, and after a search
        that returns candidates, elsewhere and the hypotheses it did not find again lose
        this factor of their mass. Conservative: it says ``localized`` far less often.
    search_rival_nats : float
        0 (the default: off). Positive: a place is not ``localized`` (by the full tests)
        while the last search, within ``replay_s``, found another place whose evidence over
        the search's replay (the log-likelihood ratio of its frames) came within this many
        nats of the place's own candidate's. The tracked place's lead may come from frames
        before the replay, against places that were tracked then; a place no search had
        proposed before enters with elsewhere's mass, which a look-alike that explained the
        frames has taken -- its evidence over the replay is the fair comparison. For maps of
        look-alikes: 3 took the simulated battery's wrong frames from 84 to 38 for 1.2 % of
        the right ones, but on runs not read while building it from 41 to 37 for 0.8 %
        (docs/tracking-notebook.md, "A rival the last search found").
    pair_search : bool
        False (default): a search proposes the places its interpretation tree finds on the
        window's bearings stacked by the odometry's rotation, which needs three distinct
        landmarks among them. True: also the places that two landmarks seen from a moving
        sensor fix (:func:`~omniloc.track.relocalize.pair_candidates`, over the last
        ``search_window_s``): a robot that sees two landmarks at a time, whose near one's
        sightings turn as it travels, is proposed too. Every pair of landmarks is tried at
        every search: for maps of at most 100 landmarks (a larger one is refused).
    replay_s : float
        New hypotheses are replayed through the frames of the last this many seconds.
    entry_replay : bool
        True (default): the candidates are replayed again from the frame of the replay at
        which elsewhere held the most mass and from the first frame of the search's window
        (``search_window_s``), where those are later than the replay's first; the entries
        are split at those frames and each part is weighed by the replay that starts it; a
        candidate takes the pose and covariance of its heaviest part's replay and is held
        to have been at its place since that part's first frame. (Elsewhere's mass, the
        prior of a place that enters at a frame, grows while the tracked places explain
        the frames and is highest at the frame of a kidnapping, before they stop
        explaining them; the frames a search found a place on are frames it explains,
        whatever came before them.) The replay from the first frame reaches a later entry
        with a state shaped by the frames before it, without their evidence: a look-alike
        sharpened by frames from before a jump that it happened to explain took the mass
        from the truth, which those frames had pulled off (the example grid's half-turn
        twins after a kidnapping), and the places found beside a look-alike, pulled off by
        frames before their search's, left it without a rival. Costs at most two replays
        more per search, over the frames from those frames on. False: each entry weighed
        with the one replay from the first frame.
    max_candidates : int
        At most this many search solutions are replayed (the search's best).
    merge_chi2 : float
        Two hypotheses closer than this squared Mahalanobis distance (on the sum of their
        covariances) ...
    merge_position_m, merge_heading : float
        ... and within this many metres and radians are one: their masses add.
    prune_weight : float
        Hypotheses holding less than this share of the mass are dropped.
    max_hypotheses : int
        At most this many hypotheses are kept (the heaviest).
    kidnap_share : float
        The place the tracker was localized at is taken to be left (flagged ``kidnapped``)
        when its mass falls below this share ...
    kidnap_watch_s : float
        ... within this many seconds of the first frame that was not ``localized`` after it
        (the clock starts at that frame: frames that stop coming while the tracker is
        localized do not start it; a frame kept by ``keep_probability`` counts as not
        localized here, so that the hysteresis does not lengthen the watch). Later the
        place is no longer watched (the estimates have not vouched for it since): on
        MRCLAM, places that stayed ``ambiguous`` for tens of seconds after their last
        ``localized`` frame and then lost their mass had lost it to the weights' swings, not
        to a kidnapping (docs/tracking.md). ``1e6`` watches a place until its mass falls.
    kidnap_confirm_s : float
        The place's mass must stay below ``kidnap_share`` for this many seconds before the
        flag is raised (0, the default: at the first frame below). A place that gets its
        mass back within that time was not left: on MRCLAM the true place loses it for a
        second or two to frames that report few of the tubes in view and then wins it
        back. The state says what it always says meanwhile (``ambiguous`` or ``lost``:
        the place no longer holds the mass); only the flag waits. The flag is raised at
        once when the tracker is ``localized`` at another place.
    kidnap_fit : float
        A place that lost its mass is flagged only if it no longer explains the bearings:
        a copy of it, as it was at the last ``localized`` frame and moved by the odometry
        alone (never corrected by the bearings, so it cannot follow them to another place),
        must explain less than this share of the bearings seen since the loss began (0.5,
        the default: most of them no longer fit; 0: the loss alone raises the flag, as
        before 2026-12-04). Nor is it flagged while the tracker's belief now (its
        hypotheses and elsewhere's particles, each weighed by the frames) explains no more
        of those bearings than the copy does (by :data:`KIDNAP_MARGIN`, half a bearing):
        bearings that no place takes for landmarks are clutter (other robots, people), not
        the evidence of another place. While either holds, the flag waits; a place that
        still explains them ``kidnap_watch_s`` after its loss began is no longer watched,
        without a flag. On MRCLAM the true place loses its mass to frames that report few
        of the tubes in view while it still explains the bearings they do report, and
        robot 5's to seconds in which every bearing is another robot
        (docs/tracking-notebook.md, "A kidnapping is a place that no longer explains the
        bearings" and "Bearings that no place explains").
    max_odometry_gap_s : float
        Odometry rows further apart than this (s) leave the motion unknown: the hypotheses
        are dropped and the tracker relocalizes.
    max_reported : int
        At most this many hypotheses in an estimate.
    confidence_hypothesis : tuple of (float, float), or None
        Knots ``(weight, confidence)`` that map each reported hypothesis's weight to the
        share of hypotheses of that weight that a recording found within tolerance of the
        truth: each :class:`~omniloc.track.Hypothesis` then carries its ``confidence``
        (None, the default: not reported).
    confidence_localized, confidence_ambiguous : tuple of (float, float), or None
        Confidence tables (:mod:`omniloc.track.confidence`): knots ``(probability,
        confidence)`` that map the tracker's own probability of a ``localized`` (an
        ``ambiguous``) frame to the share of such frames that a recording with a ground
        truth found within tolerance (:func:`~omniloc.track.fit_confidence`). With one, each
        estimate in that state carries its ``confidence``; None (default): no confidence is
        reported, only the model's ``probability``. A table holds for the tolerances, and
        the rest of the configuration, it was fitted with: after a change, fit it again
        (:func:`~omniloc.track.with_settings` drops tables a new tolerance leaves behind).
    confidence_recent : tuple of (float, float), or None
        The table of the ``ambiguous`` frames at most ``confidence_recent_s`` seconds after
        a ``localized`` one (:attr:`~omniloc.track.TrackEstimate.since_localized`): such a
        frame is right more often than one of a tracker that has not been localized yet,
        at the same probability (docs/tracking-notebook.md, "A confidence for the frames
        after a localized one"). None (default): ``confidence_ambiguous`` reads them too.
    confidence_recent_s : float
        That span, seconds (the one the table was fitted with: :func:`~omniloc.track.
        fit_confidence`'s ``recent_s``).
    confidence_hypothesis_recent : tuple of (float, float), or None
        The hypotheses' table for the frames at most ``confidence_recent_s`` seconds after a
        localized one, localized frames included (None, the default:
        ``confidence_hypothesis`` reads them too).
    confidence_backward : tuple of (float, float), or None
        The table of the frames that the pass backward over a recording reports
        ``localized`` (offline, ``track(..., backward_s=)``; :mod:`omniloc.track.backward`):
        a place carried back from a sure frame is right less often than a frame the forward
        pass localized at the same probability. None (the default): such frames report no
        ``confidence`` (not the forward pass's table, which would overstate it).
    seed : int
        Seed of elsewhere's particles (their uniform start, motion noise, resampling and
        injection): a run is the same for the same seed; other seeds show how much of a
        result is the luck of the draw.

    Raises
    ------
    InputError
        A value out of its range (the message names it).
    """

    localized_probability: float = 0.99
    tolerance_m: float = 0.3
    tolerance_heading: float = float(np.deg2rad(5.0))
    keep_probability: float | None = None
    keep_after: int = 3
    keep_unexplained: int = 0
    lost_share: float = 0.99
    kidnap_rate: float = 1e-3
    evidence_weight: float = 1.0
    region: tuple[float, float, float, float] | None = None
    region_margin_m: float = 2.0
    elsewhere_samples: int = 3000
    elsewhere_inject: float = 0.02
    min_age_s: float = 3.0
    min_confirmations: int = 2
    min_confirmations_alone: int = 0
    min_best_s: float = 0.0
    min_landmarks: int = 0
    landmarks_window_s: float = 20.0
    search_window_s: float = 1.5
    search_interval_s: float = 1.0
    search_min_bearings: int = 4
    search_max_bearings: int = 12
    search_max_spurious: int = 2
    search_max_nodes: int = 50_000
    search_timeout_s: float = 2.0
    near_range_m: float = 1.5
    candidate_cov_inflation: float = 4.0
    candidate_min_sd_m: float = 0.05
    candidate_min_sd_heading: float = float(np.deg2rad(1.0))
    fit_window_s: float = 10.0
    fit_explained: float = 0.0
    model_check: float | None = 1e-3
    model_check_s: float = 5.0
    clutter_persistence: float = 0.0
    clutter_persistence_sd: float = float(np.deg2rad(1.0))
    clutter_memory_s: float = 2.0
    split_clutter: float = 0.0
    turn_noise_s: float = 0.0
    core_share: float = 0.0
    core_sigma: float = float(np.deg2rad(0.33))
    core_update: bool = True
    temper_update: bool = False
    nonempty_frames: bool = False
    miss_weight: float = 1.0
    exclusive_landmarks: bool = False
    occlusion_width: float = 0.0
    covariance_inflation: float = 1.0
    search_miss: float | None = None
    search_rival_nats: float = 0.0
    pair_search: bool = False
    replay_s: float = 4.0
    entry_replay: bool = True
    max_candidates: int = 3000
    merge_chi2: float = 9.0
    merge_position_m: float = 0.3
    merge_heading: float = float(np.deg2rad(5.0))
    prune_weight: float = 1e-6
    max_hypotheses: int = 50
    kidnap_share: float = 0.5
    kidnap_watch_s: float = 10.0
    kidnap_confirm_s: float = 0.0
    kidnap_fit: float = 0.5
    max_odometry_gap_s: float = 2.0
    max_reported: int = 10
    confidence_localized: tuple[tuple[float, float], ...] | None = None
    confidence_ambiguous: tuple[tuple[float, float], ...] | None = None
    confidence_hypothesis: tuple[tuple[float, float], ...] | None = None
    confidence_recent: tuple[tuple[float, float], ...] | None = None
    confidence_recent_s: float = RECENT_S
    confidence_hypothesis_recent: tuple[tuple[float, float], ...] | None = None
    confidence_backward: tuple[tuple[float, float], ...] | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in _CONFIDENCE_TABLES:
                object.__setattr__(self, f.name, confidence_table(f.name, v))
                continue
            if f.name == "seed":
                whole = isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                if not (whole and 0 <= v <= SEED_MAX):
                    raise InputError(
                        f"seed must be an integer from 0 to 2**63 - 1, got {shorten(v)}"
                    )
                object.__setattr__(self, f.name, int(v))
                continue
            if f.name in _OPTIONAL_PROBABILITIES:
                if v is None:
                    continue
                if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                    raise InputError(f"{f.name} must be None or a number, got {v!r}")
                prob = finite_number(v, f.name)
                if not 0.0 < prob < 1.0:
                    raise InputError(f"{f.name} must lie strictly between 0 and 1, got {v!r}")
                object.__setattr__(self, f.name, prob)
                continue
            if f.name in _COUNTS:
                whole = isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                if not (whole and 0 <= v <= _COUNTS[f.name]):
                    raise InputError(
                        f"{f.name} must be an integer from 0 (no such test) to "
                        f"{_COUNTS[f.name]}, got {shorten(v)}"
                    )
                object.__setattr__(self, f.name, int(v))
                continue
            if f.name in _BOOLS:
                if not isinstance(v, (bool, np.bool_)):
                    raise InputError(f"{f.name} must be true or false, got {shorten(v)}")
                object.__setattr__(self, f.name, bool(v))
                continue
            if f.name == "region":
                if v is None:
                    continue
                try:
                    r = tuple(float(x) for x in v)
                except (TypeError, ValueError, OverflowError) as exc:
                    raise InputError(f"region must be (xmin, xmax, ymin, ymax), got {v!r}") from exc
                if len(r) != 4 or not all(map(math.isfinite, r)) or r[0] >= r[1] or r[2] >= r[3]:
                    raise InputError(
                        f"region must be finite (xmin, xmax, ymin, ymax) with xmin < xmax and "
                        f"ymin < ymax, got {v!r}"
                    )
                object.__setattr__(self, f.name, r)
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise InputError(f"{f.name} must be a number, got {v!r}")
            if f.name in _INTS:
                top = _INT_MAX.get(f.name, INT_MAX)
                whole = isinstance(v, (int, np.integer)) or (
                    math.isfinite(v) and float(v).is_integer()
                )
                if not (whole and 1 <= v <= top):
                    raise InputError(
                        f"{f.name} must be a positive integer of at most {top:,}, got {shorten(v)}"
                    )
                object.__setattr__(self, f.name, int(v))
                continue
            v = finite_number(v, f.name)
            if v < 0:
                raise InputError(f"{f.name} must be finite and >= 0, got {getattr(self, f.name)!r}")
            if v > VALUE_MAX:
                raise InputError(
                    f"{f.name}={v:.3g} is implausibly large (at most {VALUE_MAX:.0e}: seconds, "
                    "metres, radians and rates of a robot)"
                )
            if f.name in _SHARES and v > 1.0:
                raise InputError(f"{f.name} must lie between 0 and 1, got {v!r}")
            if f.name in _PROBABILITIES and not 0.0 < v < 1.0:
                raise InputError(f"{f.name} must lie strictly between 0 and 1, got {v!r}")
            object.__setattr__(self, f.name, v)
        for name in (
            "fit_window_s",
            "tolerance_m",
            "tolerance_heading",
            "near_range_m",
            "candidate_cov_inflation",
            "evidence_weight",
            "covariance_inflation",
            "search_window_s",
            "landmarks_window_s",
        ):
            if getattr(self, name) <= 0:
                raise InputError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if self.keep_probability is not None and self.keep_probability > self.localized_probability:
            raise InputError(
                f"keep_probability ({self.keep_probability!r}) must not exceed "
                f"localized_probability ({self.localized_probability!r}): it is the lower "
                "threshold that keeps a place localized once it has been"
            )
        if self.temper_update and not self.evidence_weight >= 1.0 / VALUE_MAX:
            raise InputError(
                f"evidence_weight must be >= {1.0 / VALUE_MAX:g} with temper_update (the "
                f"update's bearing variance is divided by it), got {self.evidence_weight!r}"
            )
        if not self.covariance_inflation >= 1.0:
            raise InputError(
                "covariance_inflation must be >= 1 (a factor below 1 would report more "
                f"certainty than the filters have), got {self.covariance_inflation!r}"
            )
        if not self.core_share < 1.0 or (self.core_share > 0 and not self.core_sigma > 0):
            raise InputError(
                f"core_share must lie in [0, 1) and core_sigma be > 0 with it, got "
                f"core_share={self.core_share!r}, core_sigma={self.core_sigma!r}"
            )
        if not self.clutter_persistence < 1.0:
            raise InputError(
                f"clutter_persistence must lie in [0, 1), got {self.clutter_persistence!r}"
            )
        if self.clutter_persistence > 0 and not self.clutter_persistence_sd > 0:
            raise InputError(
                "clutter_persistence_sd must be > 0 with clutter_persistence, got "
                f"{self.clutter_persistence_sd!r}"
            )
        if not self.split_clutter < 0.5:
            raise InputError(
                f"split_clutter must lie in [0, 0.5) (the split happens between it and 1 minus "
                f"it), got {self.split_clutter!r}"
            )
        if self.search_min_bearings < 3:
            raise InputError(
                f"search_min_bearings must be at least 3, got {self.search_min_bearings}"
            )
        for name in _HALF_TURN_ANGLES:
            v = getattr(self, name)
            if v > math.pi:
                raise InputError(
                    f"{name}={v:g} rad is more than a half turn, which no heading or bearing "
                    "error exceeds: angles are in radians (did you pass degrees?)"
                )
