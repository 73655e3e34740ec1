"""Engine-free filament odour plume and wind (Farrell et al. 2002), vectorised over puffs and query points.

Sources: Farrell et al. 2002 (the model and its defaults) and the I2Bot paper's methods (the arena),
tabulated in ``docs/parameters.md`` §5;
the I2Bot paper (§2.5.2, methods) used pompy, the Python implementation of Farrell et al. 2002.

The model
---------
- **Puffs** ``(x, y, z, r²)`` are released at each :class:`OdourSource` as a Poisson process of
  rate ``release_rate_hz``, at the source's position with ``r² = r0²``.
- Each puff moves with the wind plus white noise: per step ``dt``,
  ``p_xy += w(p) dt + σ √dt ξ`` with ξ standard normal (σ: ``puff_spread_m_per_sqrt_s``, the puff
  centre's spread relative to the mean flow, m/√s); its height stays that of its source (the wind
  and the spread are horizontal, as in pompy).
- Its size grows linearly: ``r² = r0² + γ · age`` (γ: ``growth_m2_per_s``).
- The concentration of odour k at a point x is
  ``C_k(x) = Σ_{puffs of odour k} Q / ((2π)^{3/2} r³) · exp(-|x - p|² / (2 r²))``
  (Q: the source's ``puff_amount``, so C is amount per m³); with ``planar=True`` (the default, as in
  the 2-D model I2Bot used) the vertical offset between a query and a puff is taken as 0, so the
  reading does not depend on the height of the antenna tips.
- Puffs whose centre leaves the arena rectangle are dropped; at most ``max_puffs`` are alive, and a
  release that would exceed it is not made (counted in :attr:`Plume.suppressed_releases`), so the
  memory is flat over any run: the puff arrays are allocated once.

The wind
--------
``w(t) = mean_mps + n(t)``, one coloured-noise process per component: the second-order system
``n'' + 2ζω n' + ω² n = G ω² ξ(t)`` (damping ζ, bandwidth ω rad/s, gain G, ξ unit white noise),
integrated by Euler–Maruyama, whose stationary variance is ``G² ω / (4 ζ)`` per component
(:attr:`ColouredNoise.stationary_variance`). It starts in its stationary state by default (each
plume starts in a different wind, as if it had blown for ever), or at 0.

What is simplified relative to Farrell et al. 2002: their wind is a 2-D field on a grid, advected
and diffused (k ≈ 10–20 m²/s) with the coloured noise as its boundary values. Here the wind is
spatially uniform (the same at every point, varying in time). Across the 8 m arena the diffusive
time L²/k is 3–6 s, against the noise's correlation time 1/(ζω) = 50 s, so their interior field
follows its boundary almost uniformly; the plume's meander (puffs released at different times
travel in different directions) is kept, at one update per step instead of a grid solve, and the
wind reads the same on every backend at any point. Lost: the slow spatial shear within the arena.

Units of the noise and the defaults
-----------------------------------
σ and G are written here for white noise with √dt increments, so the plume does not depend on dt.
Farrell's code, and pompy for its puff spread, multiply a standard normal by dt instead of √dt at
dt = 0.01 s: their σ = 2 and G = 2 are σ = 2 · √0.01 = 0.2 m/√s and G = 0.2 here (a wind
fluctuation of std √(0.2² · 0.2 / 0.4) ≈ 0.14 m/s per component, against a 2 m/s mean). Those are
the defaults. Other defaults: I2Bot's arena 8 × 4 m (x in [0, 8], y in [-2, 2]), mean wind (2, 0)
m/s, release 60/s, r0 0.02 m; Farrell's ζ 0.1, ω 0.2 rad/s, γ 0.001 m²/s. I2Bot kept 200 puffs at
most, but at 60/s and 2 m/s about 225 puffs are alive over 7.5 m, so that cap would throttle the
source; ``max_puffs`` is 1000 here (a memory bound that the default plume does not reach).

Bounds on the inputs
--------------------
Every parameter is refused (:class:`~neuronav.errors.ConfigError`) outside a physical range far
beyond any real plume, so that no input can overflow to inf or NaN or run for ever: release rates up
to :data:`MAX_RELEASE_RATE_HZ`, puff amounts up to :data:`MAX_PUFF_AMOUNT`, a step ``dt_s`` up to
:data:`MAX_PLUME_DT_S`, at most :data:`MAX_PUFFS` puffs and :data:`MAX_STEPS_PER_CALL` steps per
:meth:`Plume.advance`, coordinates (arena, sources, query points) within ±1000 km
(:data:`neuronav.senses.odour.MAX_COORD_M`), and
the bounds of :class:`WindConfig` and :class:`PlumeConfig` in their docstrings. A plume whose
state still stops being finite (an unstable wind integration) raises a
:class:`~neuronav.errors.SimulationError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuronav.errors import ConfigError, SimulationError, real_or_nan
from neuronav.senses.odour import MAX_COORD_M, odour_index, query_points, rasterise
from neuronav.spec.odour_scene import MAX_PLUME_DT_S, MAX_PLUME_STEPS

_NORM_3D = (2.0 * np.pi) ** 1.5
# Query points per chunk: the (points × puffs) float64 array is kept near 32 MB (one chunk for any
# realistic number of antennae).
_MAX_PAIRS_PER_CHUNK = 1 << 22
# Bounds on the inputs (see the module docstring): far beyond any real plume, and small enough that
# no sum, square or Poisson draw of them overflows.
MAX_RELEASE_RATE_HZ = 1e6
MAX_PUFF_AMOUNT = 1e9
MAX_PUFFS = 10 ** 6  # the puff arrays: 56 MB
MAX_STEPS_PER_CALL = MAX_PLUME_STEPS  # about 28 h of plume at the default 0.01 s
MAX_WIND_MPS = 100.0
MAX_NOISE_PARAMETER = 100.0  # ζ, ω (rad/s) and G of the wind noise
MIN_RADIUS_M, MAX_RADIUS_M = 1e-4, 100.0
MAX_SPREAD_M_PER_SQRT_S = 100.0
MAX_GROWTH_M2_PER_S = 100.0


def _finite(name: str, value, size: int, bound: float = MAX_COORD_M) -> tuple[float, ...]:
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = np.full(0, np.nan)
    if arr.size != size or not (np.isfinite(arr).all() and np.abs(arr).max() <= bound):
        raise ConfigError(f"{name}: expected {size} finite numbers within ±{bound:g}, got {value!r}")
    return tuple(float(v) for v in arr)


def _positive(name: str, value, allow_zero: bool = False, high: float = np.inf, low: float = 0.0) -> float:
    number = real_or_nan(value)
    if not (low <= number <= high) or not np.isfinite(number) or (number == 0 and not allow_zero):
        allowed = (f"{'>=' if allow_zero or low > 0 else '>'} {low:g}" + (f" and <= {high:g}" if high < np.inf else "")
                   + ", finite")
        raise ConfigError(f"{name}: expected a number {allowed}, got {value!r}")
    return number


def _count(name: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not low <= value <= high:
        raise ConfigError(f"{name}: expected an integer in [{low}, {high}], got {value!r}")
    return int(value)


def plume_seed(where: str, seed) -> int | np.random.Generator | None:
    """A plume's seed: None, an int >= 0 or a ``np.random.Generator``, or a ConfigError naming ``where``."""
    if seed is None or isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ConfigError(f"{where}: seed must be None, an int >= 0 or a numpy Generator, got {seed!r}")
    return int(seed)


@dataclass(frozen=True)
class OdourSource:
    """A point source of puffs.

    Parameters
    ----------
    position_m : (float, float, float)
        Where puffs are released, metres (must lie inside the plume's arena in x and y).
    release_rate_hz : float
        Mean rate of the Poisson release, puffs per second (in (0, :data:`MAX_RELEASE_RATE_HZ`]).
    odour : int
        Which odour the puffs carry (index into the concentration's last axis, in [0,
        :data:`neuronav.senses.odour.MAX_ODOURS`)).
    puff_amount : float
        Q, the amount of odour in one puff (in (0, :data:`MAX_PUFF_AMOUNT`]); concentrations are
        amount per m³.
    """

    position_m: tuple[float, float, float] = (0.5, 0.0, 0.0)
    release_rate_hz: float = 60.0
    odour: int = 0
    puff_amount: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_m", _finite("source position_m", self.position_m, 3))
        object.__setattr__(self, "release_rate_hz", _positive("source release_rate_hz", self.release_rate_hz,
                                                                 high=MAX_RELEASE_RATE_HZ))
        object.__setattr__(self, "puff_amount", _positive("source puff_amount", self.puff_amount,
                                                          high=MAX_PUFF_AMOUNT))
        object.__setattr__(self, "odour", odour_index("source odour", self.odour))


@dataclass(frozen=True)
class WindConfig:
    """Mean wind plus coloured noise (see the module docstring).

    Parameters
    ----------
    mean_mps : (float, float)
        Mean wind velocity (x, y), m/s, each within ±:data:`MAX_WIND_MPS`.
    damping : float
        ζ of the second-order noise (in (0, :data:`MAX_NOISE_PARAMETER`]).
    bandwidth_rad_s : float
        ω of the second-order noise, rad/s (in (0, :data:`MAX_NOISE_PARAMETER`]).
    gain : float
        G of the second-order noise (in [0, :data:`MAX_NOISE_PARAMETER`]; 0: a steady wind), in m/s
        per √(rad/s): the stationary variance is G² ω / (4 ζ) (m/s)².
    start_stationary : bool
        Draw the initial noise state from its stationary distribution (True) or start it at 0.
    """

    mean_mps: tuple[float, float] = (2.0, 0.0)
    damping: float = 0.1
    bandwidth_rad_s: float = 0.2
    gain: float = 0.2
    start_stationary: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "mean_mps", _finite("wind mean_mps", self.mean_mps, 2, MAX_WIND_MPS))
        object.__setattr__(self, "damping", _positive("wind damping", self.damping, high=MAX_NOISE_PARAMETER))
        object.__setattr__(self, "bandwidth_rad_s", _positive("wind bandwidth_rad_s", self.bandwidth_rad_s,
                                                              high=MAX_NOISE_PARAMETER))
        object.__setattr__(self, "gain", _positive("wind gain", self.gain, allow_zero=True, high=MAX_NOISE_PARAMETER))


@dataclass(frozen=True)
class PlumeConfig:
    """A filament plume's parameters (defaults: the I2Bot arena with Farrell's model constants).

    Parameters
    ----------
    sources : tuple of OdourSource
        One or more sources (several odours when their ``odour`` indices differ).
    wind : WindConfig
        The wind.
    puff_spread_m_per_sqrt_s : float
        σ, the white noise on each puff's centre, m/√s (in [0, :data:`MAX_SPREAD_M_PER_SQRT_S`]).
    growth_m2_per_s : float
        γ, the linear growth of r², m²/s (in [0, :data:`MAX_GROWTH_M2_PER_S`]).
    initial_radius_m : float
        r0, a new puff's radius, metres (in [:data:`MIN_RADIUS_M`, :data:`MAX_RADIUS_M`]).
    arena_x_m, arena_y_m : (float, float)
        The arena rectangle (within ±:data:`neuronav.senses.odour.MAX_COORD_M`); puffs whose centre leaves
        it are dropped.
    max_puffs : int
        Most puffs alive at once, over all sources (1 to :data:`MAX_PUFFS`).
    planar : bool
        Ignore the vertical offset between query points and puffs (the 2-D model), or not.
    """

    sources: tuple[OdourSource, ...] = (OdourSource(),)
    wind: WindConfig = WindConfig()
    puff_spread_m_per_sqrt_s: float = 0.2
    growth_m2_per_s: float = 0.001
    initial_radius_m: float = 0.02
    arena_x_m: tuple[float, float] = (0.0, 8.0)
    arena_y_m: tuple[float, float] = (-2.0, 2.0)
    max_puffs: int = 1000
    planar: bool = True

    def __post_init__(self) -> None:
        sources = (self.sources,) if isinstance(self.sources, OdourSource) else tuple(self.sources)
        if not sources or not all(isinstance(s, OdourSource) for s in sources):
            raise ConfigError(f"plume sources: expected one or more OdourSource, got {self.sources!r}")
        object.__setattr__(self, "sources", sources)
        if not isinstance(self.wind, WindConfig):
            raise ConfigError(f"plume wind: expected a WindConfig, got {type(self.wind).__name__}")
        object.__setattr__(self, "puff_spread_m_per_sqrt_s",
                           _positive("plume puff_spread_m_per_sqrt_s", self.puff_spread_m_per_sqrt_s, True,
                                     MAX_SPREAD_M_PER_SQRT_S))
        object.__setattr__(self, "growth_m2_per_s", _positive("plume growth_m2_per_s", self.growth_m2_per_s, True,
                                                              MAX_GROWTH_M2_PER_S))
        object.__setattr__(self, "initial_radius_m", _positive("plume initial_radius_m", self.initial_radius_m,
                                                               high=MAX_RADIUS_M, low=MIN_RADIUS_M))
        for name in ("arena_x_m", "arena_y_m"):
            pair = _finite(f"plume {name}", getattr(self, name), 2)
            if not pair[0] < pair[1]:
                raise ConfigError(f"plume {name}: expected (low, high) with low < high, got {getattr(self, name)!r}")
            object.__setattr__(self, name, pair)
        object.__setattr__(self, "max_puffs", _count("plume max_puffs", self.max_puffs, 1, MAX_PUFFS))
        for index, source in enumerate(sources):
            x, y, _ = source.position_m
            if not (self.arena_x_m[0] <= x <= self.arena_x_m[1] and self.arena_y_m[0] <= y <= self.arena_y_m[1]):
                raise ConfigError(f"plume source {index}: position_m {source.position_m} is outside the arena "
                                  f"x {self.arena_x_m}, y {self.arena_y_m}")

    @property
    def n_odours(self) -> int:
        """Number of odours: one more than the largest source odour index."""
        return 1 + max(s.odour for s in self.sources)


class ColouredNoise:
    """Independent second-order coloured-noise processes ``n'' + 2ζω n' + ω² n = G ω² ξ``.

    Parameters
    ----------
    damping, bandwidth_rad_s, gain : float
        ζ, ω (rad/s) and G; the stationary variance is ``G² ω / (4 ζ)``.
    size : int
        How many independent processes (components).
    rng : np.random.Generator
        Source of the white noise (and of the initial state when ``start_stationary``).
    start_stationary : bool
        Draw (n, n') from the stationary distribution (variances G²ω/(4ζ) and ω² times that,
        uncorrelated), or start at 0.
    """

    def __init__(self, damping: float, bandwidth_rad_s: float, gain: float, size: int,
                 rng: np.random.Generator, start_stationary: bool = False) -> None:
        self.damping = _positive("coloured noise damping", damping)
        self.bandwidth_rad_s = _positive("coloured noise bandwidth_rad_s", bandwidth_rad_s)
        self.gain = _positive("coloured noise gain", gain, allow_zero=True)
        self._rng = rng
        self.value = np.zeros(size)
        self.rate = np.zeros(size)
        if start_stationary:
            std = np.sqrt(self.stationary_variance)
            self.value = std * rng.standard_normal(size)
            self.rate = self.bandwidth_rad_s * std * rng.standard_normal(size)

    @property
    def stationary_variance(self) -> float:
        """G² ω / (4 ζ), the variance of each component in its stationary state."""
        return self.gain ** 2 * self.bandwidth_rad_s / (4.0 * self.damping)

    def step(self, dt_s: float) -> np.ndarray:
        """Advance by ``dt_s`` seconds (Euler–Maruyama); return the new values, shape (size,)."""
        omega, zeta = self.bandwidth_rad_s, self.damping
        kick = self.gain * omega ** 2 * np.sqrt(dt_s) * self._rng.standard_normal(self.value.shape)
        self.rate = self.rate + (-2.0 * zeta * omega * self.rate - omega ** 2 * self.value) * dt_s + kick
        self.value = self.value + self.rate * dt_s
        return self.value


class Wind:
    """A spatially uniform wind: mean plus coloured noise per component, readable at any point."""

    def __init__(self, config: WindConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._mean = np.asarray(config.mean_mps, dtype=float)
        self._noise = ColouredNoise(config.damping, config.bandwidth_rad_s, config.gain, 2, rng,
                                    config.start_stationary)

    @property
    def velocity_mps(self) -> np.ndarray:
        """The wind now, (vx, vy) m/s (the same everywhere)."""
        return self._mean + self._noise.value

    def step(self, dt_s: float) -> None:
        """Advance the noise by ``dt_s`` seconds."""
        self._noise.step(dt_s)

    def velocity_at(self, points_m) -> np.ndarray:
        """Wind at points (..., 2 or 3), m/s, shape (..., 2)."""
        points = query_points("wind query points", points_m)
        return np.broadcast_to(self.velocity_mps, points.shape[:-1] + (2,)).copy()


@dataclass(frozen=True)
class PuffState:
    """A read-only snapshot of the live puffs (n of them).

    Attributes
    ----------
    position_m : np.ndarray, (n, 3)
    r2_m2 : np.ndarray, (n,)  squared radius, m².
    age_s : np.ndarray, (n,)  time since release, s.
    odour : np.ndarray, (n,)  odour index.
    amount : np.ndarray, (n,)  Q of each puff.
    """

    position_m: np.ndarray
    r2_m2: np.ndarray
    age_s: np.ndarray
    odour: np.ndarray
    amount: np.ndarray


@dataclass
class Plume:
    """A live filament plume: puffs and wind, stepped in time, read at any points.

    Parameters
    ----------
    config : PlumeConfig
        The model's parameters.
    seed : int >= 0, np.random.Generator or None
        Seeds every random draw (release times, puff noise, wind); same seed, same plume.

    Examples
    --------
    >>> plume = Plume(PlumeConfig(), seed=1)
    >>> plume.advance(0.01, 1000)            # a 10 s warm-up before the agent starts
    >>> plume.concentration_at(tips_m)       # (agents, 2, 3) -> (agents, 2, n_odours)
    """

    config: PlumeConfig = field(default_factory=PlumeConfig)
    seed: int | np.random.Generator | None = 0
    time_s: float = field(init=False, default=0.0)
    released: int = field(init=False, default=0)
    suppressed_releases: int = field(init=False, default=0)
    dropped: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        if not isinstance(self.config, PlumeConfig):
            raise ConfigError(f"plume config: expected a PlumeConfig, got {type(self.config).__name__}")
        self._rng = np.random.default_rng(plume_seed("plume", self.seed))
        self.wind = Wind(self.config.wind, self._rng)
        cap = int(self.config.max_puffs)
        self._position = np.zeros((cap, 3))
        self._r2 = np.zeros(cap)
        self._birth_s = np.zeros(cap)
        self._odour = np.zeros(cap, dtype=np.intp)
        self._amount = np.zeros(cap)
        self._n = 0
        sources = self.config.sources
        self._source_position = np.array([s.position_m for s in sources])
        self._source_rate_hz = np.array([s.release_rate_hz for s in sources])
        self._source_odour = np.array([s.odour for s in sources], dtype=np.intp)
        self._source_amount = np.array([s.puff_amount for s in sources])
        self._n_odours = self.config.n_odours

    @property
    def n_puffs(self) -> int:
        """Puffs alive now."""
        return self._n

    @property
    def n_odours(self) -> int:
        """Length of the concentration's last axis."""
        return self._n_odours

    @property
    def puffs(self) -> PuffState:
        """A copy of the live puffs' state."""
        n = self._n
        return PuffState(self._position[:n].copy(), self._r2[:n].copy(), self.time_s - self._birth_s[:n],
                         self._odour[:n].copy(), self._amount[:n].copy())

    def advance(self, dt_s: float, steps: int = 1) -> None:
        """Advance the plume ``steps`` steps of ``dt_s`` seconds (a warm-up, or one step of the loop).

        Each step: the puffs move with the wind and their noise, grow, and those that left the arena
        are dropped; then the wind steps; then each source releases a Poisson(rate · dt) number of puffs
        (as many as ``max_puffs`` allows). ``dt_s`` in (0, :data:`MAX_PLUME_DT_S`], ``steps`` in
        [0, :data:`MAX_STEPS_PER_CALL`]; a wind or puff that stops being finite is a SimulationError.
        """
        dt = _positive("plume dt_s", dt_s, high=MAX_PLUME_DT_S)
        for _ in range(_count("plume steps", steps, 0, MAX_STEPS_PER_CALL)):
            self._step(dt)
        # One sum is finite exactly when every term is: checked once per call, not per step.
        if not np.isfinite(self.wind.velocity_mps.sum() + self._position[:self._n].sum() + self._r2[:self._n].sum()):
            raise SimulationError("plume diverged: the wind or a puff is not finite (lower dt_s or the wind's "
                                  "bandwidth_rad_s)")

    def _step(self, dt: float) -> None:
        cfg = self.config
        n = self._n
        if n:
            pos = self._position[:n]
            pos[:, :2] += self.wind.velocity_mps * dt
            if cfg.puff_spread_m_per_sqrt_s:
                pos[:, :2] += (cfg.puff_spread_m_per_sqrt_s * np.sqrt(dt)) * self._rng.standard_normal((n, 2))
            self._r2[:n] += cfg.growth_m2_per_s * dt
            (x0, x1), (y0, y1) = cfg.arena_x_m, cfg.arena_y_m
            keep = (pos[:, 0] >= x0) & (pos[:, 0] <= x1) & (pos[:, 1] >= y0) & (pos[:, 1] <= y1)
            if not keep.all():
                kept = int(keep.sum())
                for arr in (self._position, self._r2, self._birth_s, self._odour, self._amount):
                    arr[:kept] = arr[:n][keep]
                self.dropped += n - kept
                self._n = n = kept
        self.wind.step(dt)
        self.time_s += dt
        counts = self._rng.poisson(self._source_rate_hz * dt)
        total = int(counts.sum())
        if total:
            room = len(self._r2) - n
            made = min(total, room)
            self.suppressed_releases += total - made
            self.released += made
            which = np.repeat(np.arange(len(counts)), counts)[:made]
            sl = slice(n, n + made)
            self._position[sl] = self._source_position[which]
            self._r2[sl] = cfg.initial_radius_m ** 2
            self._birth_s[sl] = self.time_s
            self._odour[sl] = self._source_odour[which]
            self._amount[sl] = self._source_amount[which]
            self._n = n + made

    def concentration_at(self, points_m) -> np.ndarray:
        """Concentration of every odour at points (..., 3) (or (..., 2): in the puffs' plane), amount/m³.

        Returns
        -------
        np.ndarray, shape (..., n_odours)
            One array operation over (points × puffs), whatever the number of agents and antennae.
        """
        points = query_points("plume query points", points_m)
        lead = points.shape[:-1]
        n = self._n
        if n == 0:
            return np.zeros(lead + (self._n_odours,))
        flat = points.reshape(-1, points.shape[-1])
        dims = 2 if (self.config.planar or points.shape[-1] == 2) else 3
        centres = self._position[:n, :dims]
        r2 = self._r2[:n]
        amplitude = self._amount[:n] / (_NORM_3D * r2 * np.sqrt(r2))
        if self._n_odours == 1:
            weights = amplitude[:, None]
        else:
            weights = np.zeros((n, self._n_odours))
            weights[np.arange(n), self._odour[:n]] = amplitude
        # -|x - p|² / (2 r²) = x·p / r² - |x|² / (2 r²) - |p|² / (2 r²): one matrix product of the
        # points [x, |x|², 1] with the puffs [p / r², -1 / (2 r²), -|p|² / (2 r²)] gives every exponent.
        half_inv_r2 = 0.5 / r2
        puff_terms = np.vstack([centres.T / r2, -half_inv_r2, -np.einsum("pk,pk->p", centres, centres) * half_inv_r2])
        out = np.empty((len(flat), self._n_odours))
        chunk = max(1, _MAX_PAIRS_PER_CHUNK // n)
        for lo in range(0, len(flat), chunk):
            q = flat[lo:lo + chunk, :dims]
            point_terms = np.hstack([q, np.einsum("qk,qk->q", q, q)[:, None], np.ones((len(q), 1))])
            exponent = point_terms @ puff_terms
            np.minimum(exponent, 0.0, out=exponent)
            out[lo:lo + chunk] = np.exp(exponent, out=exponent) @ weights
        return out.reshape(lead + (self._n_odours,))

    def wind_at(self, points_m) -> np.ndarray:
        """Wind at points (..., 2 or 3), m/s, shape (..., 2)."""
        return self.wind.velocity_at(points_m)

    def rasterise(self, x_range_m=None, y_range_m=None, shape_px=(200, 400), odour: int = 0,
                  z_m: float | None = None) -> np.ndarray:
        """One odour's concentration as an (H, W) image over a rectangle (default: the arena).

        Row 0 is at the largest y (see :func:`neuronav.senses.odour.rasterise`); ``z_m`` is the height of
        the sampled plane (ignored when ``planar``; None: the puffs' own plane).
        """
        if not (isinstance(odour, int | np.integer) and 0 <= odour < self._n_odours):
            raise ConfigError(f"plume odour: expected an index in [0, {self._n_odours}), got {odour!r}")
        if z_m is not None:
            z_m = _finite("plume rasterise z_m", z_m, 1)[0]
        x_range = self.config.arena_x_m if x_range_m is None else x_range_m
        y_range = self.config.arena_y_m if y_range_m is None else y_range_m
        plume = self

        class _Layer:
            def concentration_at(self, points_m):
                points = np.asarray(points_m, dtype=float)
                if z_m is not None:
                    points = np.concatenate([points, np.full(points.shape[:-1] + (1,), z_m)], axis=-1)
                return plume.concentration_at(points)[..., odour]

        return rasterise(_Layer(), x_range, y_range, shape_px)
