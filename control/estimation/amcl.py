"""Monte Carlo localisation of a robot's laser scans against the map (AMCL).

The algorithm of Probabilistic Robotics (Thrun, Burgard, Fox 2005) ch. 8 as Nav2's ``amcl`` runs it
(ros-navigation/navigation2, ``nav2_amcl``), compiled in :mod:`control.estimation.amcl_kernels`:

- **Motion**: the odometry motion model (table 5.6) with ``alpha1..alpha4``, applied to every
  particle when the odometry has moved more than ``update_min_d`` along x or y or ``update_min_a``
  in heading since the last update (Nav2's per-axis test); the scan is used only then.
- **Sensor**: the likelihood-field model over ``max_beams`` evenly spaced beams (Nav2's step
  ``(beams - 1) // (max_beams - 1)``), ``p = 1 + sum pz^3``, ``pz = z_hit exp(-d^2 / 2 sigma_hit^2) +
  z_rand / range_max`` with ``d`` the distance from a beam's end point to the nearest mapped
  obstacle or wall, capped at ``laser_likelihood_max_dist``, read at the nearest node of the
  ``map_resolution`` grid as Nav2 reads its map's cell (``pz^3`` is tabulated there once). Beams
  at or beyond the range limit (``min(laser_max_range, the scan's range_max)``) or at or below the
  scan's ``range_min`` (or ``laser_min_range``, when above it; REP 117 infinities among them) are left out,
  as Nav2 does.
- **Resampling**: low-variance (table 4.4) with the set's size chosen by KLD sampling (Fox 2003;
  bins of 0.5 m x 0.5 m x 10 deg, ``pf_err``, ``pf_z``, between ``min_particles`` and
  ``max_particles``), every ``resample_interval`` updates.
- **Recovery**: random particles over the free space with probability ``max(0, 1 - w_fast /
  w_slow)`` (augmented MCL, table 8.3; ``recovery_alpha_slow``, ``recovery_alpha_fast``, 0 = off).
- **Estimate**: the weighted mean and covariance of the heaviest cluster (the particles within one
  bin of the bin of most weight), then, with ``refine`` on (nhsim's addition; Nav2 has none), a
  Gauss-Newton scan-to-map fit of the used beams' end points to the map's signed distance (from the
  surface each beam's ray meets: :func:`amcl_kernels.beam_residual`) from that mean and from the last
  estimate moved by the odometry (the fit whose objective, a truncated quadratic of every weighed beam,
  :func:`amcl_kernels.fit_cost`, is smaller wins; :func:`amcl_kernels.refine` gives it at its pose), over every
  valid beam (not only the ``max_beams`` subset).
  Given the scanner's white range noise (``range_noise``: the LDS-01's datasheet precision, an
  absolute standard deviation near and a relative one beyond the split), each beam is weighted by
  its inverse variance (the maximum-likelihood fit: a far beam's noise grows with its range, and
  weighing them all alike let the far ones move the pose; measured on two random worlds' static
  poses with exact map and scanner but for the noise, the weighted fit's position errors were 4.0
  and 4.5 mm RMS against 6.8 and 8.3 mm, and its ``(J^T W J)^-1`` consistent, mean NEES 2.8 and 3.0,
  where the unweighted fit's ``s^2 (J^T J)^-1`` gave 4.5 and 6.2). Beams read within a band about
  the split of the scanner's systematic error are left out: by the reading alone, their error may be
  the offset or the scale (:func:`amcl_kernels.beam_weight`).
  The fit (continued from where it stopped for another round of steps, as one started far off may not
  have settled) gives the estimate only when it explains the scan (:meth:`Amcl.agreement`): at least
  :data:`FIX_SHARE` of the beams it weighs within ``refine_gate`` of the map, and at most
  :data:`FIX_THROUGH` of them with rays that cross a mapped surface well before their reading
  (:meth:`Amcl.see_through`, as global localisation's search judges its poses). Else the heaviest
  cluster's mean and covariance stand (the cloud's own uncertainty, tens of centimetres): a fit from the
  mean of a cloud that has not converged can land on a wrong pose whose end points lie on walls, and its
  ``(J^T W J)^-1`` would report that pose to centimetres.
  When the fit holds (at least half the beams the particles weigh, ``max_beams`` or the scan's own when it has
  fewer, within ``refine_gate``, and it explains the scan) its
  covariance is the white noise's ``(J^T W J)^-1`` (times the chi-square per degree of freedom where that is above
  1; without ``range_noise``, ``W`` = I and the factor is the residual variance ``s^2``) plus, given the scanner's
  systematic range error (``range_bias``: a relative scale error beyond a split range and an
  offset nearer, as the LDS-01's datasheet states its accuracy), that error carried through the
  fit, ``G diag(var_scale, var_offset) G^T`` with ``G = -(J^T W J)^-1 J^T W u`` and ``u`` each beam's
  residual change per unit of each error (:func:`amcl_kernels.fit_sensitivity`): the pose moves
  with the scanner's scale where the walls in range do not surround it, and not where they do.
  Without ``range_bias`` the larger of ``s^2 (J^T J)^-1`` and the cluster's covariance stands, the
  cluster's spread standing for the systematic error the fit does not know. (The cluster's
  covariance is that of Nav2's particle cloud, tens of centimetres at its alphas: given to an EKF
  as a fix's, it leaves dead reckoning uncorrected; measured on a seeded random world, the
  estimate drifted 4 cm from an accurate localiser into an obstacle.)
  Where the scan fixes some directions of the pose only (a corridor's two walls with both ends out of range fix
  the position across it and the heading, nothing along it), the fit's information is singular and the whole
  fit is not taken; the fit from the cloud's mean within the directions it fixes is
  (:func:`observed_directions`, :func:`amcl_kernels.refine_within`), its pose the cloud's along the others, its
  covariance the fit's within the fixed directions and the cloud's across the others (measured on a 12 x 1.2 m
  corridor: across it 1.1 mm RMS and 0.09 deg against 25 mm and 2.2 deg from the cloud, NEES mean 1.4).

Global localisation (nhsim's addition) searches the whole free space for one scan
(:meth:`Amcl.search`): the likelihood field scores a grid of poses, the best are refined by the fit, and
each refined pose's beams are also cast through the map (:meth:`Amcl.see_through`: a ray that crosses a
mapped surface well before its reading says the pose is wrong, which the end points alone cannot). When a
distinct pose explains the scan about as well as the best (:data:`ALIKE_BEAMS`, :data:`ALIKE_RESIDUAL`),
the search reports the scan ambiguous with the poses.

The map is the world's own signed distance (:func:`planning.collision.field.signed_distances`,
the planner's formulas), tabulated once per world on a ``map_resolution`` grid and read bilinearly.

Defaults are Nav2's (``nav2_bringup/params/nav2_params.yaml``, ``amcl``): alpha1-4 0.2,
laser_likelihood_max_dist 2.0, laser_max_range 100.0, laser_min_range -1.0, max_beams 60, min/max_particles 500/2000,
pf_err 0.05, pf_z 0.99, recovery_alpha_slow/fast 0.0, resample_interval 1, sigma_hit 0.2,
update_min_a 0.2, update_min_d 0.25, z_hit 0.5, z_rand 0.5; its initial covariance (AMCL's
``initial_cov_xx/yy/aa`` defaults) 0.25 m^2, 0.25 m^2, (pi/12)^2 rad^2.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from control.estimation import amcl_kernels as K
from planning.collision.field import signed_distances
from planning.core.arrays import kernel_input
from planning.core.checks import check_number
from planning.core.world import World
from planning.errors import ConfigError, option

FloatArray = NDArray[np.float64]

#: KLD histogram bins (Nav2's pf kd-tree): 0.5 m in x and y, 10 deg in heading.
BIN_XY = 0.5
BIN_TH = math.radians(10.0)
#: Poses of a correlative search refined by the scan-to-map fit.
SEARCH_KEPT = 20
#: Fewest valid beams (finite, within the range limits) of a scan the localiser takes: fewer cannot fix a
#: pose (the search refuses them; the scan localiser delivers no fix from such a revolution).
MIN_BEAMS = 10
#: Two poses of a search are distinct beyond this distance [m] (global localisation's convergence spread) ...
DISTINCT_XY = 0.2
#: ... or this heading difference [rad].
DISTINCT_THETA = math.radians(20.0)
#: A distinct pose explains a scan as well as the search's best (the scan is ambiguous) when its agreement
#: (beams within the fit's gate of the map less beams whose rays cross a mapped surface well before their
#: reading, :meth:`Amcl.see_through`) is at least this share of the best's ...
ALIKE_BEAMS = 0.97
#: ... and its chi-square per beam at most this multiple of the best's. Measured on the first scan of global
#: localisation (docs/explanation/lidar-amcl.md): a symmetric world's twins 1.000 and 1.00; on the built-in
#: and random worlds the nearest distinct pose had at most 0.952 of the agreement (nav_map2, its chi-square
#: per beam 8.1 times the best's), and where its chi-square was within 1.25 times, at most 0.813.
ALIKE_RESIDUAL = 1.25
#: A tracking fit gives the estimate only when at least this share of the valid beams it weighs
#: (:meth:`Amcl.fitted`) ends within ``refine_gate`` of the map: most of them. Not the 0.8 global
#: localisation's search needs to seed: tracking past an unmapped obstacle hides more of the map (the
#: unmapped box of ``tests/test_scan_localiser.py`` beside the open arena's line: correct fits, 0.7-2.8 cm
#: off, at 0.774-0.919). The share does not tell wrong fits apart (those below,
#: 0.899-1.000); the rays do ...
FIX_SHARE = 0.5
#: ... and at most this share of them have rays that cross a mapped surface well before their reading
#: (:meth:`Amcl.see_through`); else the particles' cluster gives it, with its own covariance. Measured by
#: ``tests/test_localiser_honesty.py::test_the_ray_test_separates_correct_fits_from_wrong_ones`` (slow; 30 runs,
#: docs/explanation/lidar-amcl.md "A fix the scan contradicts"): over 609 updates of correct fits (nav_map1,
#: nav_map2, farm, parking_lot, random9001-9003, random9005, known starts with noise seeds 0-3, and starts
#: 0.45 m off that recovered) at most 0.032 of the rays crossed and at least 0.992 of the beams were in the
#: gate; the four wrong fits from starts 0.45 m off (nav_map2 and nav_map1, 43-63 cm off with centimetre sigmas)
#: had 0.138-0.197 crossing (and 0.899-0.969 in the gate: the share alone does not tell them). 0.05 lies
#: between, 1.6 times the largest right (a fifth wrong fit, farm's, had 0.086 before the fit's second round).
FIX_THROUGH = 0.05
#: The distance field reaches this far beyond the walls [m] (end points of beams that pass a wall
#: by a little, from a particle a little off, land there).
GRID_MARGIN = 0.5
#: A valid ``--amcl`` text, quoted in messages.
EXAMPLE = "max_particles=1000,refine=0"
#: The fields that are whole numbers (given as floats by ``--amcl``, stored as ints).
#: Nav2 AMCL parameters (``nav2_amcl``'s ``amcl`` block) that nhsim's localiser does not take, and why: an
#: ``amcl:`` block copied from a Nav2 configuration is refused key by key with the reason, not as a typo.
NAV2_ONLY = {
    **dict.fromkeys(
        ("z_max", "z_short", "lambda_short"),
        "a weight of Nav2's beam model; nhsim's AMCL is its likelihood_field model (z_hit, z_rand, sigma_hit)",
    ),
    "laser_model_type": "nhsim's AMCL is Nav2's likelihood_field model, the only one it has; leave it out",
    **dict.fromkeys(
        ("do_beamskip", "beam_skip_distance", "beam_skip_threshold", "beam_skip_error_threshold"),
        "beam skipping (off in Nav2's defaults) is not implemented; leave it out",
    ),
    "alpha5": "the omnidirectional motion model's; the robots are differential drive (Nav2's alpha1-alpha4)",
    "robot_model_type": "the robots are differential drive (nav2_amcl::DifferentialMotionModel); leave it out",
    **dict.fromkeys(
        ("set_initial_pose", "initial_pose", "always_reset_initial_pose"),
        "give the pose estimate with --initial-pose X,Y,THETA",
    ),
    **dict.fromkeys(
        (
            "base_frame_id",
            "global_frame_id",
            "odom_frame_id",
            "scan_topic",
            "map_topic",
            "tf_broadcast",
            "transform_tolerance",
            "save_pose_rate",
            "first_map_only",
            "use_sim_time",
            "introspection_mode",
        ),
        "ROS plumbing with no part in the simulation; leave it out",
    ),
}
WHOLE_FIELDS = ("max_beams", "min_particles", "max_particles", "resample_interval", "refine")
#: Largest particle set a configuration may ask for (a set of that size takes ~50 MB and seconds a scan).
MAX_PARTICLES = 1_000_000


@dataclass(frozen=True)
class AmclConfig:
    """The localiser's parameters (Nav2's names and defaults; see the module docstring).

    Attributes:
        alpha1: Rotation noise from rotation [-].
        alpha2: Rotation noise from translation [rad^2/m^2].
        alpha3: Translation noise from translation [-].
        alpha4: Translation noise from rotation [m^2/rad^2].
        z_hit: Weight of the hit component [-].
        z_rand: Weight of the random component [-].
        sigma_hit: Standard deviation of the hit component [m].
        laser_likelihood_max_dist: Cap of the map distance [m].
        laser_max_range: Longest range used [m] (the scan's own limit applies too).
        laser_min_range: Shortest range used [m]: beams at or below it are left out; 0 or less (Nav2's -1.0)
            uses the scan's own ``range_min``, which applies anyway.
        max_beams: Beams used per scan [-].
        min_particles: Smallest set [-] (>= 10).
        max_particles: Largest set [-].
        pf_err: KLD error bound [-].
        pf_z: KLD quantile (Nav2 uses the value itself as the normal quantile) [-].
        recovery_alpha_slow: Slow average's rate [-], 0 = no recovery.
        recovery_alpha_fast: Fast average's rate [-].
        resample_interval: Updates between resamplings [-].
        update_min_d: Travel before an update [m].
        update_min_a: Rotation before an update [rad].
        initial_std_xy: Initial standard deviation in x and y [m].
        initial_std_theta: Initial standard deviation of heading [rad].
        map_resolution: Spacing of the tabulated distance field [m].
        refine: 1 to refine the estimate by scan-to-map fitting, 0 for plain AMCL.
        refine_gate: Largest map distance of a beam used by the fit [m].
        roughen_xy: Standard deviation of the jitter added to every particle by an update without
            motion (``force``; global localisation of a standing robot) [m] (Gordon's roughening).
        roughen_theta: The same in heading [rad].
    """

    alpha1: float = 0.2
    alpha2: float = 0.2
    alpha3: float = 0.2
    alpha4: float = 0.2
    z_hit: float = 0.5
    z_rand: float = 0.5
    sigma_hit: float = 0.2
    laser_likelihood_max_dist: float = 2.0
    laser_max_range: float = 100.0
    laser_min_range: float = -1.0
    max_beams: int = 60
    min_particles: int = 500
    max_particles: int = 2000
    pf_err: float = 0.05
    pf_z: float = 0.99
    recovery_alpha_slow: float = 0.0
    recovery_alpha_fast: float = 0.0
    resample_interval: int = 1
    update_min_d: float = 0.25
    update_min_a: float = 0.2
    initial_std_xy: float = 0.5
    initial_std_theta: float = math.pi / 12
    map_resolution: float = 0.025
    refine: int = 1
    refine_gate: float = 0.3
    roughen_xy: float = 0.05
    roughen_theta: float = 0.05

    def __post_init__(self) -> None:
        example = f"e.g. {option('amcl', EXAMPLE)}"
        for f in fields(self):  # checked, kept as given (a whole-number field is stored as an int below)
            low = None if f.name == "laser_min_range" else 0.0  # Nav2's -1.0: the scan's own
            check_number(f"amcl {f.name}", getattr(self, f.name), at_least=low, fix=example)
        for name in WHOLE_FIELDS:
            v = getattr(self, name)  # a finite number >= 0: the option's text gives 1000.0, a whole number
            whole = check_number(f"amcl {name}", int(v) if v == int(v) else v, integer=True, at_least=0, fix=example)
            object.__setattr__(self, name, whole)
        if self.min_particles < 10:
            raise ConfigError(f"amcl min_particles={self.min_particles} is below 10; give at least 10 (Nav2: 500)")
        if self.max_particles < self.min_particles:
            raise ConfigError(
                f"amcl max_particles={self.max_particles} is below min_particles={self.min_particles}; raise it"
            )
        if self.max_particles > MAX_PARTICLES:
            raise ConfigError(
                f"amcl max_particles={self.max_particles} is above {MAX_PARTICLES:,}: each particle is resampled and "
                f"scored every scan (Nav2's default is 2000); give at most {MAX_PARTICLES}"
            )
        positive = ("sigma_hit", "pf_err", "pf_z", "map_resolution", "max_beams", "resample_interval")
        for name in (*positive, "laser_likelihood_max_dist", "laser_max_range"):
            if getattr(self, name) <= 0:
                raise ConfigError(f"amcl {name} must be > 0, got {getattr(self, name)!r}")
        if self.map_resolution > MAX_MAP_RESOLUTION:
            raise ConfigError(
                f"amcl map_resolution must be at most {MAX_MAP_RESOLUTION:g} m (the likelihood field's grid; Nav2's "
                f"maps are 0.05 m), got {self.map_resolution:g}"
            )
        if self.max_beams < 2:
            raise ConfigError(f"amcl max_beams must be at least 2, got {self.max_beams}")
        if self.laser_min_range >= self.laser_max_range:
            raise ConfigError(
                f"amcl laser_min_range={self.laser_min_range:g} is not below laser_max_range={self.laser_max_range:g}: "
                "no beam would be used; lower it (-1 uses the scan's own range_min, Nav2's default)"
            )
        if self.refine not in (0, 1):
            raise ConfigError(f"amcl refine must be 0 or 1, got {self.refine}")
        self._check_fractions()

    def _check_fractions(self) -> None:
        """The mixture weights and rates that are fractions (Probabilistic Robotics sec. 6.4, 8.3.5)."""
        for name in ("z_hit", "z_rand", "recovery_alpha_slow", "recovery_alpha_fast", "pf_err"):
            if getattr(self, name) > 1:
                raise ConfigError(f"amcl {name} must be a fraction in [0, 1], got {getattr(self, name)!r}")
        if self.z_hit == 0:
            raise ConfigError("amcl z_hit must be > 0: with no hit component the scan moves no particle")
        if self.z_hit + self.z_rand > 1 + 1e-9:
            raise ConfigError(
                f"amcl z_hit + z_rand = {self.z_hit + self.z_rand:g} exceeds 1: they are the weights of one mixture "
                "(Nav2: z_hit=0.5,z_rand=0.5); lower one of them"
            )
        slow, fast = self.recovery_alpha_slow, self.recovery_alpha_fast
        if slow > 0 and not slow < fast:
            raise ConfigError(
                f"amcl recovery_alpha_slow={slow:g} must be below recovery_alpha_fast={fast:g} (the slow average "
                "of the likelihood against the fast one; e.g. 0.001 and 0.1), or 0 to turn recovery off"
            )

    def range_limits(self, range_min: float, range_max: float) -> tuple[float, float]:
        """The ranges the sensor model uses, exclusive, from a scan's limits [m]: within its own, and within
        ``laser_min_range`` (when above 0) and ``laser_max_range`` (Nav2's rule)."""
        return max(range_min, self.laser_min_range), min(range_max, self.laser_max_range)

    def override(self, table: Mapping[str, object], what: str = "[amcl]") -> AmclConfig:
        """This configuration with the keys of ``table`` replaced.

        Raises:
            ConfigError: An unknown key or a bad value.
        """
        names = [f.name for f in fields(self)]
        unknown = [k for k in table if k not in names]
        if unknown and unknown[0] in NAV2_ONLY:
            raise ConfigError(f"{what}: {unknown[0]!r} is not taken: {NAV2_ONLY[unknown[0]]}")
        if unknown:
            raise ConfigError(f"{what}: unknown localiser key {unknown[0]!r}; the keys are {', '.join(names)}")
        values: dict[str, Any] = {**asdict(self), **table}
        return AmclConfig(**values)

    def parse(self, text: str) -> AmclConfig:
        """This configuration with ``key=value,...`` (``--amcl``) applied.

        Raises:
            ConfigError: A malformed part, an unknown key or a bad value.
        """
        table: dict[str, float] = {}
        for part in filter(None, (p.strip() for p in text.split(","))):
            key, sep, value = part.partition("=")
            try:
                table[key.strip()] = float(value) if sep else float("nan")
            except ValueError:
                if key.strip() not in {f.name for f in fields(self)}:  # a key not taken: say so, whatever its value
                    self.override({key.strip(): value}, option("amcl", text))
                raise ConfigError(
                    f"{option('amcl', text)}: {key.strip()} must be a finite number, got {value!r}, e.g. {EXAMPLE}"
                ) from None  # float()'s own error adds nothing
            if not sep:
                raise ConfigError(f"{option('amcl', text)}: expected key=value pairs, e.g. {EXAMPLE}; got {part!r}")
        return self.override(table, option("amcl", text))

    def as_dict(self) -> dict[str, float]:
        """Plain-dict view for records."""
        return asdict(self)


@dataclass(frozen=True)
class LikelihoodField:
    """A world's distance field, tabulated once (see :func:`likelihood_field`).

    Attributes:
        capped: (nx, ny) ``min(max(sd, 0), cap)``: the likelihood model's distance [m].
        signed: (nx, ny) ``clip(sd, -cap, cap)``: the refinement's signed distance [m].
        grid: (x0, y0, h, cap, slope): origin [m], spacing [m], the value outside the grid, and the bound on
            ``signed``'s change per metre (:func:`amcl_kernels.field_slope`).
        free: (F, 2) centres of the cells at least ``clearance`` from every obstacle and wall.
    """

    capped: FloatArray
    signed: FloatArray
    grid: FloatArray
    free: FloatArray


#: Coarsest ``map_resolution`` [m]: a grid coarser than the robot (0.1 m of free space kept about each free cell)
#: has nothing to localise in (``map_resolution=10`` said only that the map had no free space).
MAX_MAP_RESOLUTION = 0.5
#: Most cells of the likelihood field (:func:`likelihood_field`): building it takes about 100 bytes a cell
#: (its tables and their making), so this is about 1.6 GB, a 100 x 100 m world at the default 0.025 m.
MAX_FIELD_CELLS = 16_000_000


@functools.lru_cache(maxsize=8)
def likelihood_field(world: World, resolution: float, cap: float, clearance: float = 0.1) -> LikelihoodField:
    """The world's signed distance (walls included) on a grid of spacing ``resolution`` [m], reaching
    :data:`GRID_MARGIN` beyond the walls.

    Args:
        world: The map: what the planner knows.
        resolution: Grid spacing [m].
        cap: Largest distance kept (``laser_likelihood_max_dist``) [m].
        clearance: Free cells are at least this far from obstacles and walls [m].

    Raises:
        ConfigError: The grid would have more than :data:`MAX_FIELD_CELLS` cells (the message names the
            coarsest ``map_resolution`` that fits, and the other localiser).
    """
    m = GRID_MARGIN
    xmin, xmax, ymin, ymax = (float(v) for v in np.asarray(world.bounds) + np.array([-m, m, -m, m]))
    nx = math.ceil((xmax - xmin) / resolution) + 1
    ny = math.ceil((ymax - ymin) / resolution) + 1
    if nx * ny > MAX_FIELD_CELLS:
        fits = math.ceil(math.sqrt((xmax - xmin) * (ymax - ymin) / (0.9 * MAX_FIELD_CELLS)) * 1000.0) / 1000.0
        raise ConfigError(
            f"the scan localiser's likelihood field of this {world.width:g} x {world.height:g} m world at "
            f"map_resolution {resolution:g} m has {nx * ny:.3g} cells, more than the {MAX_FIELD_CELLS:.3g} it "
            f"builds (about {100 * nx * ny / 1e9:.3g} GB); localise on a coarser map, "
            f"{option('amcl', f'map_resolution={fits:g}')}, or with the synthetic fixes, {option('localiser', 'fixes')}"
        )
    xx, yy = np.meshgrid(xmin + resolution * np.arange(nx), ymin + resolution * np.arange(ny), indexing="ij")
    pts = np.ascontiguousarray(np.column_stack([xx.ravel(), yy.ravel()]))
    sd = signed_distances(world, pts, resolution).reshape(nx, ny)
    capped = np.minimum(np.maximum(sd, 0.0), cap)
    signed = np.clip(sd, -cap, cap)
    free = pts[sd.ravel() >= clearance]
    if free.shape[0] == 0:
        raise ConfigError(f"the map has no free space {clearance} m from its obstacles and walls to localise in")
    grid = np.array([xmin, ymin, resolution, cap, K.field_slope(signed, resolution)])
    for a in (capped, signed, free, grid):
        a.setflags(write=False)
    return LikelihoodField(capped, signed, grid, np.ascontiguousarray(free))


def scan_returns(ranges: ArrayLike, range_min: float, range_max: float) -> NDArray[np.int64]:
    """The returns of a scan, (beams,) ranges, or of each of (S, beams) scans: its ranges within
    (``range_min``, ``range_max``) (REP 117: -inf too close, +inf nothing within range)."""
    z = np.asarray(ranges, dtype=float)
    return np.asarray(np.count_nonzero(np.isfinite(z) & (z > range_min) & (z < range_max), axis=-1), dtype=np.int64)


def beam_subset(n: int, max_beams: int) -> NDArray[np.int64]:
    """Indices of the beams used of ``n`` (Nav2: every ``(n - 1) // (max_beams - 1)``-th, at least 1)."""
    step = max(1, (n - 1) // (max_beams - 1))
    return np.arange(0, n, step, dtype=np.int64)


@dataclass(frozen=True)
class AmclEstimate:
    """The localiser's answer after an update.

    Attributes:
        pose: (3,) estimated pose (x, y, theta) [m, m, rad].
        cov: (3, 3) its covariance.
        particles: Size of the particle set [-].
        spread: Root of the trace of the whole set's (x, y) covariance [m].
        refined: Whether the scan-to-map fit gave the pose.
        range_gain: (3, 2) the pose's change per unit of the scanner's relative scale error and per
            metre of its offset (``-(J^T W J)^-1 J^T W u``, :func:`amcl_kernels.fit_sensitivity`), when the
            fit gave the pose and the scanner's systematic error is known (``range_bias``); else None.
        noise_cov: (3, 3) the covariance without the scanner's systematic error, ``cov - range_gain
            diag(var_scale, var_offset) range_gain^T``, with ``range_gain``; else None.
        agreement: The fit's (share of the weighed beams within the gate, share whose rays cross a mapped
            surface well before their reading) (:meth:`Amcl.agreement`), when a fit was tried to the end
            (``refined`` False with it: the fit did not explain the scan, :data:`FIX_SHARE`,
            :data:`FIX_THROUGH`); else None.
    """

    pose: FloatArray
    cov: FloatArray
    particles: int
    spread: float
    refined: bool
    range_gain: FloatArray | None = None
    noise_cov: FloatArray | None = None
    agreement: tuple[float, float] | None = None


class SearchResult(NamedTuple):
    """A correlative search's answer (:meth:`Amcl.search`).

    Attributes:
        pose: (3,) the pose that explains the scan best.
        share: Share of the scan's valid beams within ``refine_gate`` of the map there.
        poses: (P, 3) the distinct poses that explain it alike (the best first); more than one: ambiguous.
        rival: (agreement, chi-square per beam) of the best distinct pose after it, as multiples of the
            best's (None: no other distinct pose among those refined): how near the scan came to ambiguous.
    """

    pose: FloatArray
    share: float
    poses: FloatArray
    rival: tuple[float, float] | None

    @property
    def ambiguous(self) -> bool:
        """Whether distinct poses explain the scan alike."""
        return self.poses.shape[0] > 1


def _distinct(a: FloatArray, b: FloatArray) -> bool:
    """Whether two poses are farther apart than :data:`DISTINCT_XY` or :data:`DISTINCT_THETA`."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) > DISTINCT_XY or abs(K.angle_diff(a[2], b[2])) > DISTINCT_THETA


def _alike(fits: list[tuple[FloatArray, int, float, int]], share: float) -> SearchResult:
    """The search's answer from its refined poses ``(pose, agreement, chi-square per beam, beams within the
    gate)``, best first: the distinct poses whose agreement is at least :data:`ALIKE_BEAMS` of the best's and
    whose chi-square per beam is at most :data:`ALIKE_RESIDUAL` times its."""
    best, agree, res, _ = fits[0]
    poses, rival = [best], None
    for pose, a, r, _ in fits[1:]:
        if not _distinct(pose, best):
            continue
        if rival is None:
            rival = (a / agree if agree > 0 else math.nan, r / res if res > 0 else math.inf if r > 0 else 1.0)
        if a >= ALIKE_BEAMS * agree and r <= ALIKE_RESIDUAL * res and all(_distinct(pose, p) for p in poses):
            poses.append(pose)
    out = np.array(poses)
    out[:, 2] = np.remainder(out[:, 2] + math.pi, 2 * math.pi) - math.pi
    return SearchResult(out[0].copy(), share, out, rival)


class Amcl:
    """Adaptive Monte Carlo localisation on a known map (see the module docstring).

    Args:
        world: The map (what the planner knows; unmapped obstacles left out).
        config: Parameters.
        laser: (3,) the scanner's pose in the robot's frame (x, y, yaw) [m, m, rad].
        seed: Seed of the localiser's own random numbers.
        clearance: Random particles are drawn this far from obstacles and walls [m].
        range_bias: The scanner's systematic range error as (split [m], standard deviation of the
            offset below it [m], of the relative scale error from it [-]) for the refined pose's
            covariance; None: the fit's or the cluster's, the larger.
        range_noise: The scanner's white range noise as (split [m], standard deviation below it [m],
            relative standard deviation from it [-], the band below and above the split whose beams
            are left out [m]): the fit weighs each beam by its inverse variance
            (:func:`amcl_kernels.beam_weight`); None: every beam alike.
    """

    def __init__(
        self,
        world: World,
        config: AmclConfig,
        laser: ArrayLike,
        seed: int,
        *,
        clearance: float = 0.1,
        range_bias: tuple[float, float, float] | None = None,
        range_noise: tuple[float, float, float, float, float] | None = None,
    ):
        self.config = config
        self.range_bias = range_bias
        self.range_noise = range_noise
        self._noise = kernel_input(K.NO_NOISE_MODEL if range_noise is None else range_noise)
        self.field = likelihood_field(world, config.map_resolution, config.laser_likelihood_max_dist, clearance)
        self.laser = np.asarray(laser, dtype=float).reshape(3)
        self.rng = np.random.default_rng(seed)
        xmin, xmax, ymin, ymax = world.bounds
        self.bins = np.array([xmin - 1.0, ymin - 1.0, BIN_XY, BIN_TH])
        self.shape = np.array(
            [math.ceil((xmax - xmin + 2.0) / BIN_XY), math.ceil((ymax - ymin + 2.0) / BIN_XY), 36], dtype=np.int64
        )
        self.alphas = np.array([config.alpha1, config.alpha2, config.alpha3, config.alpha4])
        self.particles = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self.odom_ref: FloatArray | None = None
        self.w_slow = self.w_fast = 0.0
        self.updates = 0
        self.estimate: AmclEstimate | None = None
        self._table: tuple[float, FloatArray, float] | None = None  # (range_max, pz^3 grid, pz^3 off it)

    def reset(self, pose: ArrayLike, std_xy: float | None = None, std_theta: float | None = None) -> None:
        """Start from a Gaussian cloud of ``max_particles`` around ``pose`` (Nav2's initial pose)."""
        c = self.config
        sxy = c.initial_std_xy if std_xy is None else std_xy
        sth = c.initial_std_theta if std_theta is None else std_theta
        n = c.max_particles
        self.particles = np.asarray(pose, dtype=float).reshape(1, 3) + self.rng.standard_normal((n, 3)) * [
            sxy,
            sxy,
            sth,
        ]
        self._restart()

    def reset_global(self) -> None:
        """Start from ``max_particles`` spread uniformly over the free space, headings uniform."""
        self.particles = self._random_poses(self.config.max_particles)
        self._restart()

    def search(
        self, ranges: FloatArray, range_min: float, range_max: float, bearings: FloatArray, *, step: float = 0.2
    ) -> SearchResult:
        """Correlative search of the whole free space for one scan (global localisation's seed): the
        likelihood-field score of poses on a ``step`` grid of free positions x 10 deg headings, the best
        :data:`SEARCH_KEPT` refined by the scan-to-map fit, and whether distinct poses explain the scan alike.

        A refined pose is ranked by its agreement (its valid beams within ``refine_gate`` of the map, less
        the beams whose rays cross a mapped surface well before their reading, :meth:`see_through`), then
        its chi-square per beam. The scan is ambiguous when a pose farther than :data:`DISTINCT_XY` or
        :data:`DISTINCT_THETA` from the best has at least :data:`ALIKE_BEAMS` of its agreement and a
        chi-square per beam within :data:`ALIKE_RESIDUAL` times its: a symmetric world's twins, which no
        scan taken standing still tells apart. A scan of fewer than :data:`MIN_BEAMS` valid beams is not
        searched (its answer: the first pose tried, share 0, not ambiguous).

        Args:
            ranges: (beams,) the scan's ranges [m].
            range_min, range_max: Its limits [m].
            bearings: (beams,) each beam's bearing [rad].
            step: Grid spacing of the positions tried [m].
        """
        c = self.config
        free = self.field.free
        keep = np.unique(np.round(free / step).astype(np.int64), axis=0) * step
        heads = np.arange(36) * BIN_TH
        cand = np.column_stack([np.repeat(keep, heads.size, axis=0), np.tile(heads, keep.shape[0])])
        r, b = self.beams(ranges, range_min, range_max, 0.0, 0.0, bearings=bearings)
        ra, ba = self.beams(ranges, range_min, range_max, 0.0, 0.0, every=True, bearings=bearings)
        if ra.size < MIN_BEAMS:
            return SearchResult(cand[0], 0.0, cand[:1].copy(), None)
        w = np.ones(cand.shape[0])
        self._sense_weights(cand, w, r, b, c.range_limits(range_min, range_max)[1])
        fits = []  # (pose, consistent beams, chi-square per beam, beams within the gate)
        for i in np.argsort(-w)[:SEARCH_KEPT]:
            pose, _, _, used, ssr, _ = K.refine(
                cand[i], ra, ba, self.laser, self.field.signed, self.field.grid, c.refine_gate, 10, self._noise
            )
            through = self.see_through(pose, ranges, bearings, range_min, range_max)
            fits.append((pose, used - through, ssr / max(used, 1), used))
        fits.sort(key=lambda f: (-f[1], f[2]))
        return _alike(fits, fits[0][3] / max(self.fitted(ra), 1))

    def fitted(self, r: FloatArray) -> int:
        """How many of the valid beams ``r`` [m] the fit weighs: all but those read within the band about the
        scanner's error split, which it leaves out on purpose (:func:`amcl_kernels.beam_weight`)."""
        return int(K.weighed_beams(np.ascontiguousarray(r, dtype=float), self._noise))

    def see_through(
        self, pose: FloatArray, ranges: FloatArray, bearings: FloatArray, range_min: float, range_max: float
    ) -> int:
        """Beams of a scan whose rays, cast from ``pose``, cross a mapped surface well before their reading
        (for a beam that read nothing, before the range limit): a scan taken there would have seen that
        surface (the likelihood field and the fit look at the end points alone). Well before: by more than
        ``refine_gate`` plus the scanner's error at that range (:meth:`_through_margin`). Beams below
        ``range_min`` are left out. The map is read at the nearest node of its grid, every grid spacing along
        each ray."""
        f, (rmin, rmax) = self.field, self.config.range_limits(range_min, range_max)
        z = np.asarray(ranges, dtype=float)
        ok = z > rmin  # NaN and -inf (too close) left out
        r = np.ascontiguousarray(np.where(z[ok] < rmax, z[ok], rmax))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        lx = pose[0] + c * self.laser[0] - s * self.laser[1]
        ly = pose[1] + s * self.laser[0] + c * self.laser[1]
        a = np.ascontiguousarray(pose[2] + self.laser[2] + np.asarray(bearings, dtype=float)[ok])
        return int(K.rays_through(lx, ly, a, r, f.signed, f.grid, self._through_margin()))

    def _through_margin(self) -> FloatArray:
        """How much longer than a mapped surface's distance ``d`` [m] a reading may be before its ray counts as
        crossing the surface, as (``a``, ``b``): ``a + b d`` [m], ``refine_gate`` plus the scanner's whole
        systematic band (3 standard deviations of ``range_bias``'s scale error) and 3 standard deviations of
        its white noise (``range_noise``) at that range; without them, the LDS-01's (5 % and 3.5 %: 15.5 % of
        ``d``)."""
        scale = 0.05 / 3 if self.range_bias is None else self.range_bias[2]
        white = 0.035 if self.range_noise is None else self.range_noise[2]
        return np.array([self.config.refine_gate, 3.0 * (scale + white)])

    def _restart(self) -> None:
        n = self.particles.shape[0]
        self.weights = np.full(n, 1.0 / n)
        self.odom_ref, self.estimate = None, None
        self.w_slow = self.w_fast = 0.0
        self.updates = 0

    def _random_poses(self, n: int) -> FloatArray:
        free, h = self.field.free, self.field.grid[2]
        pick = free[self.rng.integers(0, free.shape[0], n)] + self.rng.uniform(-h / 2, h / 2, (n, 2))
        return np.column_stack([pick, self.rng.uniform(-math.pi, math.pi, n)])

    def beams(
        self,
        ranges: FloatArray,
        range_min: float,
        range_max: float,
        angle_min: float,
        angle_increment: float,
        *,
        every: bool = False,
        bearings: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """The beams the sensor model uses: Nav2's subset (or, with ``every``, all: the refinement's), within
        (:meth:`AmclConfig.range_limits`).

        Args:
            bearings: (beams,) each beam's bearing [rad], given instead of ``angle_min + i * angle_increment``
                (a scan deskewed by the robot's own motion).

        Returns:
            (B,) ranges [m] and (B,) bearings [rad].
        """
        idx = np.arange(ranges.size) if every else beam_subset(ranges.size, self.config.max_beams)
        r = ranges[idx]
        rmin, rmax = self.config.range_limits(range_min, range_max)
        ok = np.isfinite(r) & (r > rmin) & (r < rmax)
        b = angle_min + angle_increment * idx[ok] if bearings is None else np.asarray(bearings, dtype=float)[idx[ok]]
        return np.ascontiguousarray(r[ok]), np.ascontiguousarray(b)

    def moved_enough(self, odom: FloatArray) -> bool:
        """Whether the odometry moved past ``update_min_d`` (in x or y) or ``update_min_a`` since the last update."""
        if self.odom_ref is None:
            return True
        d = odom - self.odom_ref
        da = abs(K.angle_diff(float(odom[2]), float(self.odom_ref[2])))
        return bool(
            abs(d[0]) > self.config.update_min_d
            or abs(d[1]) > self.config.update_min_d
            or da > self.config.update_min_a
        )

    def update(
        self,
        odom: ArrayLike,
        ranges: ArrayLike,
        range_min: float,
        range_max: float,
        angle_min: float,
        angle_increment: float,
        *,
        force: bool = False,
        bearings: FloatArray | None = None,
    ) -> bool:
        """Take one scan with the odometry pose at its time; update if moved enough (or ``force``).

        Args:
            odom: (3,) odometry pose (dead reckoning) at the scan's time.
            ranges: (beams,) the scan's ranges [m] (REP 117).
            range_min, range_max: The scan's limits [m].
            angle_min, angle_increment: The scan's bearings [rad].
            force: Update without motion (Nav2's ``nomotion_update``).
            bearings: (beams,) each beam's bearing [rad], instead of the evenly spaced ones.

        Returns:
            Whether the filter updated (then :attr:`estimate` is new).
        """
        if self.particles.shape[0] == 0:
            raise RuntimeError("the localiser has no particles: call reset() or reset_global() first")
        o = np.asarray(odom, dtype=float).reshape(3)
        if not (force or self.moved_enough(o)):
            return False
        if force and self.config.roughen_xy + self.config.roughen_theta > 0:
            jitter = self.rng.standard_normal((self.particles.shape[0], 3))
            self.particles += jitter * [self.config.roughen_xy, self.config.roughen_xy, self.config.roughen_theta]
        prior = None
        if self.odom_ref is not None and self.estimate is not None:  # the last estimate moved by the odometry since
            prior = _moved(self.estimate.pose, self.odom_ref, o)
        self._move(o)
        z = np.asarray(ranges, dtype=float)
        limits = (range_min, range_max, angle_min, angle_increment)
        r, b = self.beams(z, *limits, bearings=bearings)
        self._sense(r, b, self.config.range_limits(range_min, range_max)[1])
        self.updates += 1
        if self.updates % self.config.resample_interval == 0:
            self._resample()
        every = bearings if bearings is not None else angle_min + angle_increment * np.arange(z.size)
        scan = (z, np.asarray(every, dtype=float), range_min, range_max)
        self.estimate = self._estimate(*self.beams(z, *limits, every=True, bearings=bearings), prior, scan)
        return True

    def predict(self, odom: ArrayLike) -> bool:
        """Move the particles by the odometry since the last update without weighing them: a revolution with no
        beam to weigh (every surface beyond the scanner's range, in the middle of a large open space). Nav2's
        AMCL applies its motion model on every scan once the robot has moved enough, whatever the beams; a
        filter that skipped such scans stood still while the robot drove on (12 m across an empty 12 x 12 m
        arena), and was then 16 m off. The estimate is the cloud's (its heaviest cluster's mean and covariance).

        Args:
            odom: (3,) odometry pose at the scan's time.

        Returns:
            Whether it moved (the robot moved enough since the last update, :meth:`moved_enough`).
        """
        if self.particles.shape[0] == 0:
            raise RuntimeError("the localiser has no particles: call reset() or reset_global() first")
        o = np.asarray(odom, dtype=float).reshape(3)
        if not self.moved_enough(o):
            return False
        self._move(o)
        self.estimate = self._estimate(np.zeros(0), np.zeros(0))  # no beam to fit: the cloud's
        return True

    def _move(self, odom: FloatArray) -> None:
        """The motion update: every particle moved by the odometry from the last update's to ``odom``, with the
        motion model's noise (``alpha1..4``); the first call only notes the odometry."""
        if self.odom_ref is not None:
            normals = self.rng.standard_normal((self.particles.shape[0], 3))
            K.motion_update(self.particles, self.odom_ref, odom, self.alphas, normals)
        self.odom_ref = odom.copy()

    def _sense_weights(
        self, particles: FloatArray, weights: FloatArray, r: FloatArray, b: FloatArray, rmax: float
    ) -> float:
        """:func:`amcl_kernels.likelihood_update` with this map's ``pz^3`` table (made once per range limit)."""
        c = self.config
        if self._table is None or self._table[0] != rmax:
            model = np.array([c.z_hit, c.z_rand, c.sigma_hit, rmax])
            far = float(K.pz_cubed(np.array([c.laser_likelihood_max_dist]), model)[0])
            self._table = (rmax, np.ascontiguousarray(K.pz_cubed(self.field.capped, model)), far)
        _, table, outside = self._table
        return float(K.likelihood_update(particles, weights, r, b, self.laser, table, self.field.grid, outside))

    def _sense(self, r: FloatArray, b: FloatArray, rmax: float) -> None:
        c = self.config
        total = self._sense_weights(self.particles, self.weights, r, b, rmax)
        n = self.weights.size
        w_avg = total / n
        self.weights /= total
        self.w_slow = w_avg if self.w_slow == 0.0 else self.w_slow + c.recovery_alpha_slow * (w_avg - self.w_slow)
        self.w_fast = w_avg if self.w_fast == 0.0 else self.w_fast + c.recovery_alpha_fast * (w_avg - self.w_fast)

    def _resample(self) -> None:
        c = self.config
        m = c.max_particles
        w_diff = max(0.0, 1.0 - self.w_fast / self.w_slow) if self.w_slow > 0 else 0.0
        offset = float(self.rng.uniform())
        order = self.rng.permutation(m).astype(np.int64)
        coins, randoms = (
            (self.rng.uniform(size=m), self._random_poses(m)) if w_diff > 0 else (np.zeros(0), np.zeros((0, 3)))
        )
        out = np.empty((m, 3))
        kld = np.array([c.pf_err, c.pf_z, float(c.min_particles)])
        n = K.resample(
            self.particles, self.weights, offset, order, w_diff, coins, randoms, self.bins, self.shape, kld, out
        )
        self.particles = out[:n].copy()
        self.weights = np.full(n, 1.0 / n)

    def _estimate(
        self,
        r: FloatArray,
        b: FloatArray,
        prior: FloatArray | None = None,
        scan: tuple[FloatArray, FloatArray, float, float] | None = None,
    ) -> AmclEstimate:
        """The estimate from the particles and the valid beams ``r``, ``b``: the fit's pose and covariance when
        it explains the scan (:meth:`explains`, given the whole ``scan`` as (ranges, bearings, range_min,
        range_max) for its rays), else the heaviest cluster's mean and covariance."""
        mean, cov, _ = K.cluster_estimate(self.particles, self.weights, self.bins, self.shape)
        spread = self.spread()
        c = self.config
        # half the beams the particles weigh (Nav2's subset: max_beams of the scan's, fewer when it has fewer)
        least = max(MIN_BEAMS, min(c.max_beams, r.size if scan is None else scan[0].size) // 2)
        cloud = AmclEstimate(mean, cov, self.particles.shape[0], spread, False)
        if not c.refine or r.size < least:
            return cloud
        scan_map: ScanMap = (r, b, self.laser, self.field.signed, self.field.grid, c.refine_gate, 10, self._noise)
        chosen = self._best_fit(mean, prior, scan_map, least)
        if chosen is None:
            return cloud
        best, basis = chosen
        # on from where it stopped: a fit started far off (an unconverged cloud) may not have settled in its steps
        pose, info, _, used, ssr, _ = K.resume(best, *scan_map, basis)
        pose[2] = math.atan2(math.sin(pose[2]), math.cos(pose[2]))
        agreement = self.agreement(pose, used, r, scan)
        if agreement[0] < FIX_SHARE or agreement[1] > FIX_THROUGH:  # the fit does not explain the scan
            return AmclEstimate(mean, cov, self.particles.shape[0], spread, False, agreement=agreement)
        whole = basis is K.WHOLE
        held = np.zeros((3, 3)) if whole else _outside(basis) @ cov @ _outside(basis)  # the cloud's, where unfixed
        if self.range_bias is not None:
            noise, gain, bias = self._fit_cov(pose, r, b, basis)
            return AmclEstimate(
                pose, _psd(noise + bias + held), self.particles.shape[0], spread, True, gain, _psd(noise + held),
                agreement,
            )  # fmt: skip
        # the fit's own covariance knows only the scan's white noise, not its systematic error: the larger
        # of it and the cluster's is reported
        fit_cov = self._white_scale(ssr, used) * _within(basis, info)
        if not whole:
            return AmclEstimate(pose, _psd(fit_cov + held), self.particles.shape[0], spread, True, agreement=agreement)
        cov = np.maximum(fit_cov, cov) if np.all(np.diag(cov) > 0) else cov
        return AmclEstimate(pose, _psd(cov), self.particles.shape[0], spread, True, agreement=agreement)

    def _best_fit(
        self, mean: FloatArray, prior: FloatArray | None, scan_map: ScanMap, least: int
    ) -> tuple[K.Fit, FloatArray] | None:
        """The scan-to-map fit the estimate takes, with the basis it moved in (:data:`amcl_kernels.WHOLE`, or the
        directions the scan fixes): of the fits from the cloud's ``mean`` and the ``prior``, the one of smaller
        objective among those with ``least`` beams in it that stayed within 0.5 m of their start and whose
        information is well conditioned; with none, and where the scan fixes some directions only (a corridor's
        walls fix the position across it and the heading, nothing along it: its information is singular there),
        the fit from the mean within those directions (:func:`observed_directions`), held along the others; else
        None (the cloud's estimate)."""
        best: K.Fit | None = None
        for start in (mean,) if prior is None else (mean, prior):
            fit = K.refine(start, *scan_map)
            pose, info, _, used, _, cost = fit
            if used < least or math.hypot(pose[0] - start[0], pose[1] - start[1]) >= 0.5:
                continue
            if np.linalg.cond(info) < 1e8 and (best is None or cost < best[5]):  # the fit's objective, every beam
                best = fit
        if best is not None:
            return best, K.WHOLE
        _, at_mean, _, near, _, _ = K.refine(mean, *scan_map[:6], 0, scan_map[7])  # what the scan gives there
        basis = None if near < least else observed_directions(at_mean)  # too few beams: not a corridor, lost
        if basis is None:
            return None
        fit = K.refine_within(mean, *scan_map, basis)
        pose, _, _, used, _, _ = fit
        if used < least or math.hypot(pose[0] - mean[0], pose[1] - mean[1]) >= 0.5:
            return None
        return fit, basis

    def agreement(
        self, pose: FloatArray, used: int, r: FloatArray, scan: tuple[FloatArray, FloatArray, float, float] | None
    ) -> tuple[float, float]:
        """How well a fit at ``pose`` with ``used`` beams within the gate explains a scan whose valid beams are
        ``r``: (the share of the beams it weighs within the gate, :meth:`fitted`; the share of them whose rays
        cross a mapped surface well before their reading, :meth:`see_through`, 0 without the whole ``scan``)."""
        n = max(self.fitted(r), 1)
        through = 0 if scan is None else self.see_through(pose, *scan)
        return used / n, through / n

    def _fit_cov(
        self, pose: FloatArray, r: FloatArray, b: FloatArray, basis: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The refined pose's covariance in two parts, the white noise's ``(J^T W J)^-1`` (scaled by
        :meth:`_white_scale`) and the scanner's systematic error (``range_bias``) carried through the fit
        (see the module docstring), with the fit's gain: (noise (3, 3), gain (3, 2), systematic (3, 3)); for a fit
        within some directions only (``basis`` not :data:`amcl_kernels.WHOLE`), within those (:func:`_within`)."""
        assert self.range_bias is not None
        split, sd_offset, sd_scale = self.range_bias
        ata, used, ssr = K.fit_sensitivity(pose, r, b, self.laser, self.field.signed, self.field.grid,
                                           self.config.refine_gate, split, self._noise)  # fmt: skip
        inv = _within(basis, ata[:3, :3])
        gain: FloatArray = -(inv @ ata[:3, 3:])
        noise: FloatArray = self._white_scale(ssr, used) * inv
        systematic: FloatArray = gain @ np.diag([sd_scale**2, sd_offset**2]) @ gain.T
        return noise, gain, systematic

    def _white_scale(self, ssr: float, used: int) -> float:
        """The factor of a fit's ``(J^T W J)^-1`` for its white noise: the residuals' variance ``s^2``
        without a noise model (``W`` = I); with one, 1, or the chi-square per degree of freedom where the
        residuals are larger than the scanner's noise explains (an unmapped surface within the gate)."""
        per_dof = ssr / max(used - 3, 1)
        return max(per_dof, 1e-8) if self.range_noise is None else max(per_dof, 1.0)

    def spread(self) -> float:
        """Root of the trace of the whole particle set's weighted (x, y) covariance [m]."""
        w = self.weights
        xy = self.particles[:, :2]
        mu = w @ xy
        return float(math.sqrt(max(0.0, float(w @ np.sum((xy - mu) ** 2, axis=1)))))


#: A scan and its map as the fit takes them: (ranges, bearings, laser, signed field, grid, gate, iterations, noise)
#: (:func:`amcl_kernels.refine`'s arguments after the pose).
ScanMap = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, float, int, FloatArray]

#: A direction the scan fixes carries at least this share of the largest information's eigenvalue
#: (:func:`observed_directions`).
OBSERVED_SHARE = 1e-6


def observed_directions(info: FloatArray) -> FloatArray | None:
    """The directions of the pose a scan fixes, as orthonormal columns of a (3, 3) basis (a zero column for each
    it does not): the eigenvectors of the fit's information ``J^T W J`` whose eigenvalue is at least
    :data:`OBSERVED_SHARE` of the largest, read-only (as :data:`amcl_kernels.WHOLE`). None when it fixes all three or
    none (nothing to hold apart)."""
    w, v = np.linalg.eigh(0.5 * (info + info.T))
    keep = w >= OBSERVED_SHARE * max(float(w[-1]), 0.0)
    if keep.all() or not keep.any() or not w[-1] > 0.0:
        return None
    basis = np.ascontiguousarray(v * keep)
    basis.flags.writeable = False  # as amcl_kernels.WHOLE is: the fitting kernels compile for one basis type
    return basis


def _within(basis: FloatArray, a: FloatArray) -> FloatArray:
    """``B (B^T a B)^-1 B^T`` over ``basis``'s non-zero columns ``B``: ``a``'s inverse within the directions a
    partial fit moved in (0 across the others); for a whole fit (:data:`amcl_kernels.WHOLE`), ``a``'s inverse."""
    if basis is K.WHOLE:
        return np.asarray(np.linalg.inv(a), dtype=np.float64)
    cols = basis[:, np.any(basis != 0.0, axis=0)]
    return np.asarray(cols @ np.linalg.inv(cols.T @ a @ cols) @ cols.T, dtype=np.float64)


def _outside(basis: FloatArray) -> FloatArray:
    """The projection onto the directions ``basis`` leaves out (``I - B B^T``)."""
    return np.asarray(np.eye(3) - basis @ basis.T, dtype=np.float64)


def _psd(cov: FloatArray) -> FloatArray:
    """``cov`` made symmetric positive definite (eigenvalues at least 1e-10)."""
    sym = 0.5 * (cov + cov.T)
    w, v = np.linalg.eigh(sym)
    return np.asarray((v * np.maximum(w, 1e-10)) @ v.T)


def _moved(pose: FloatArray, old: FloatArray, new: FloatArray) -> FloatArray:
    """``pose`` moved by the odometry's motion from ``old`` to ``new`` (in the odometry's own frame)."""
    dx, dy = new[0] - old[0], new[1] - old[1]
    c, s = math.cos(old[2]), math.sin(old[2])
    fx, fy = c * dx + s * dy, -s * dx + c * dy  # the motion in the robot's frame at old
    cp, sp = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + cp * fx - sp * fy, pose[1] + sp * fx + cp * fy, pose[2] + K.angle_diff(new[2], old[2])])
