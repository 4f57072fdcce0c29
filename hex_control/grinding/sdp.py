"""Stochastic dynamic programming for grinding sequences (seed 002 sections 5.2-5.7).

State: time remaining t (s; negative = late) and material remaining X (mm; negative =
overground) on a grid. At every state the planner chooses
    GRIND (F_N, V_f): a pass of duration L/V_f + t_R (eq. 5.6), landing on a stage boundary;
          its expected penalty is the integral of eq. 5.3, E[J(t - d, X - delta)], with J
          interpolated linearly in X and delta drawn from the stochastic model;
    WAIT: do nothing for one stage (before the deadline);
    QUIT: end the job now (optimal stopping, 5.5) and pay C(X) + lateness charge.
With a fixed deadline (no lateness) J(0, X) = C(X) and passes must end by the deadline.

Vectorization: the cut depth does not depend on X, so on the uniform X grid the
expectation is a correlation of J with a kernel per control, K[k] = P(interpolation
weight at a shift of k grid steps). The kernels are computed once, as spectra; each
stage's J (extended by its end values, as the lookup holds it constant beyond the grid)
is transformed once per feed, and the correlation of a feed with all its forces is one
product of spectra and one inverse real FFT (:class:`CutCorrelation`): the same sums as a
Toeplitz matrix product, to rounding (1e-16 of J's largest value), and faster where the
kernels are wide (``hexctl bench sdp``). Stages
closer together than the shortest pass do not depend on each other, so a whole block of
them is one product per feed. Controls within that rounding of the best tie; the tie goes
to the lowest force and the fastest feed.

Units: mm, N, s; penalties in charge units.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from hex_control.grinding.model import GrindingProcess
from hex_control.grinding.penalties import DeadlineCharge, InPathCharges, LatenessCharge, SideCharge
from hex_control.grinding.stochastic import CutDepthModel

WAIT, GRIND, QUIT = 0, 1, 2
ACTION_NAMES = {WAIT: "wait", GRIND: "grind", QUIT: "quit"}


#: the modules a policy solve evaluates: scipy.fft, and scipy.special for the cut PDFs
NUMERICS = ("scipy.fft", "scipy.special")


def import_numerics() -> None:
    """Import NUMERICS (about 0.15 s of CPU). A planner does it off its executor once it has
    started, so that the first goal's solve does not, with the plant's clock standing meanwhile."""
    import importlib

    for name in NUMERICS:
        importlib.import_module(name)


@dataclass(frozen=True)
class PlannerGrid:
    """The discretized state and control spaces."""

    material_min_mm: float = -1.0
    material_max_mm: float = 2.0
    material_states: int = 301
    time_step_s: float = 2.0
    horizon_s: float = 120.0  # largest time remaining
    late_horizon_s: float = 0.0  # grinding allowed this long past the deadline; 0 = fixed deadline
    forces: int = 32
    feeds: int = 8

    def __post_init__(self):
        if not self.material_min_mm < 0 < self.material_max_mm:
            raise ValueError("the material grid must span 0 (material_min_mm < 0 < material_max_mm)")
        if self.material_states < 3 or self.forces < 1 or self.feeds < 1:
            raise ValueError("need >= 3 material states, >= 1 force, >= 1 feed")
        if not (self.time_step_s > 0 and self.horizon_s >= self.time_step_s and self.late_horizon_s >= 0):
            raise ValueError("need time_step_s > 0, horizon_s >= time_step_s, late_horizon_s >= 0")

    def covering(self, time_remaining_s: float, material_mm: float) -> PlannerGrid:
        """This grid, grown at its own steps until it holds the state (t, X) with a stage
        and a material step to spare: a job beyond the grid is planned, not clamped."""
        grid = self
        if time_remaining_s > self.horizon_s:
            grid = replace(grid, horizon_s=math.ceil(time_remaining_s / self.time_step_s) * self.time_step_s)
        if material_mm + self.material_step_mm > self.material_max_mm:
            extra = math.ceil((material_mm - self.material_max_mm) / self.material_step_mm) + 1
            grid = replace(grid, material_max_mm=self.material_max_mm + extra * self.material_step_mm,
                           material_states=self.material_states + extra)
        return grid

    @property
    def material_mm(self) -> np.ndarray:
        return np.linspace(self.material_min_mm, self.material_max_mm, self.material_states)

    @property
    def material_step_mm(self) -> float:
        return (self.material_max_mm - self.material_min_mm) / (self.material_states - 1)

    @property
    def time_s(self) -> np.ndarray:
        """Stage times (time remaining), ascending from -late_horizon_s."""
        low = -round(self.late_horizon_s / self.time_step_s) * self.time_step_s
        count = round((self.horizon_s - low) / self.time_step_s) + 1
        return low + self.time_step_s * np.arange(count)


@dataclass(frozen=True)
class Charges:
    deadline: DeadlineCharge = field(default_factory=DeadlineCharge)
    lateness: LatenessCharge = field(default_factory=LatenessCharge)
    in_path: InPathCharges = field(default_factory=InPathCharges)


def charges_from_dict(data: dict) -> Charges:
    """The charges of a planner YAML's ``charges`` section; what it leaves out keeps the
    defaults of :mod:`hex_control.grinding.penalties`."""
    deadline = {name: SideCharge(**value) if name in ("over", "under") else float(value)
                for name, value in data.get("deadline", {}).items()}
    lateness = data.get("lateness")
    return Charges(DeadlineCharge(**deadline), LatenessCharge(SideCharge(**lateness)) if lateness else LatenessCharge(),
                   InPathCharges(**data.get("in_path", {})))


@dataclass(frozen=True)
class Controls:
    """The control set: forces (n_F,), pass durations in stages (n_V,), feeds (n_V,),
    feasibility (n_F, n_V), mean cut depth and its standard deviation (n_F, n_V) in mm."""

    forces_n: np.ndarray
    duration_stages: np.ndarray
    feeds_mm_s: np.ndarray
    feasible: np.ndarray
    mean_cut_mm: np.ndarray
    cut_std_mm: np.ndarray


def build_controls(process: GrindingProcess, grid: PlannerGrid, cut_model: CutDepthModel) -> Controls:
    """Forces from just above the zero-cut force to F_max; feeds whose passes last a whole
    number of stages (as the thesis did), fastest first, at most ``grid.feeds`` of them."""
    dt = grid.time_step_s
    shortest = math.ceil((process.bead_length_mm / process.feed_max_mm_s + process.reset_time_s) / dt - 1e-9)
    longest = math.floor((process.bead_length_mm / process.feed_min_mm_s + process.reset_time_s) / dt + 1e-9)
    shortest = max(shortest, math.floor(process.reset_time_s / dt) + 1)
    if longest < shortest:
        raise ValueError("no feed speed gives a pass of a whole number of stages: refine time_step_s")
    durations = np.unique(np.round(np.linspace(shortest, longest, min(grid.feeds, longest - shortest + 1))).astype(int))
    feeds = process.bead_length_mm / (durations * dt - process.reset_time_s)
    f0 = process.zero_cut_force_n()
    forces = np.linspace(f0 + (process.force_max_n - f0) / grid.forces, process.force_max_n, grid.forces)
    force_grid, feed_grid = np.meshgrid(forces, feeds, indexing="ij")
    mean = process.cut_depth_mm(force_grid, feed_grid)
    std = np.broadcast_to(cut_model.std_mm(process, force_grid, feed_grid), mean.shape)
    return Controls(forces, durations, feeds, process.feasible(force_grid, feed_grid), mean, std)


TAIL = 1e-12  # probability left out at each end of a kernel
ROUNDING = 1e-13  # the FFT correlation's error, relative to the largest |J| it transforms (measured: 1e-16)


def transition_offsets(cut_model: CutDepthModel, mean_mm, std_mm, step_mm: float) -> np.ndarray:
    """Offsets m (in material steps) that a cut can move the state by: every m whose hat
    function overlaps the cut-depth range between the TAIL and 1 - TAIL quantiles."""
    low = np.floor(np.min(cut_model.ppf(mean_mm, std_mm, TAIL)) / step_mm) - 1
    high = np.ceil(np.max(cut_model.ppf(mean_mm, std_mm, 1 - TAIL)) / step_mm) + 1
    return np.arange(int(low), int(high) + 1)


def transition_weights(cut_model: CutDepthModel, mean_mm, std_mm, step_mm: float, offsets) -> np.ndarray:
    """P-weights w[..., m] with E[J(X_i - delta)] = sum_m w[m] J_(i-m) for J linear between
    nodes ``step_mm`` apart: E[hat(m h - delta)] from the integrated CDF (exact)."""
    h = step_mm
    mean, std = np.asarray(mean_mm, float)[..., None], np.asarray(std_mm, float)[..., None]
    g = cut_model.integrated_cdf(mean, std, np.concatenate([offsets[:1] - 1, offsets, offsets[-1:] + 1]) * h)
    return (g[..., 2:] - 2 * g[..., 1:-1] + g[..., :-2]) / h


def _kernels(cut_model: CutDepthModel, mean_mm: np.ndarray, std_mm: np.ndarray, step_mm: float, feasible):
    """Correlation kernels of one feed's feasible forces: (k_low, K (n_F, n_k)) such that
    E[J(X_i - delta)] = sum_k K[f, k] J[i - k_low - k] with linear interpolation of J."""
    if not np.any(feasible):
        return 0, np.zeros((0, 1))
    mean_mm, std_mm = mean_mm[feasible], std_mm[feasible]
    offsets = transition_offsets(cut_model, mean_mm, std_mm, step_mm)
    return int(offsets[0]), transition_weights(cut_model, mean_mm, std_mm, step_mm, offsets)


class CutCorrelation:
    """E[J(X_i - delta)] at every material node i, for every force of a feed, by FFT.

    With J held at its end values beyond the grid (as the lookup holds it),
    E[i] = sum_k K[k] J[clip(i - low - k)] = (K * J_padded)[i + pad_low - low], J padded by
    pad_low = low + n_k - 1 on the left and pad_high = -low on the right (at least 0); a
    transform at least as long as the padded row keeps those entries free of wrap-around.
    Each feed has its own length (its kernels' width): a J row is transformed once per feed
    (``spectra``), and serves all that feed's forces.
    """

    def __init__(self, kernels: list[tuple[int, np.ndarray]], n_x: int):
        import scipy.fft  # here: the nodes that only read the grid and the charges start 0.15 s sooner

        self.fft = scipy.fft
        self.n_x, self.kernels = n_x, kernels
        self.pads = [(max(0, low + kernel.shape[1] - 1), max(0, -low)) for low, kernel in kernels]
        self.lengths = [self.fft.next_fast_len(n_x + left + right, real=True) for left, right in self.pads]
        self.first = [left - low for (left, _), (low, _) in zip(self.pads, kernels)]
        self.kernel_spectra = [self.fft.rfft(kernel, n=n, axis=1) for (_, kernel), n in zip(kernels, self.lengths)]

    @classmethod
    def of(cls, controls: Controls, cut_model: CutDepthModel, step_mm: float, n_x: int) -> CutCorrelation:
        """The correlation of every feed's feasible forces on a grid of ``n_x`` nodes ``step_mm`` apart."""
        return cls([_kernels(cut_model, controls.mean_cut_mm[:, v], controls.cut_std_mm[:, v], step_mm,
                             controls.feasible[:, v]) for v in range(len(controls.feeds_mm_s))], n_x)

    def empty_spectra(self, rows: int) -> list[np.ndarray]:
        """Room for the spectra of ``rows`` J rows, per feed."""
        return [np.empty((rows, n // 2 + 1), complex) for n in self.lengths]

    def spectra(self, rows: np.ndarray) -> list[np.ndarray]:
        """Per feed, the spectra of J rows (rows, n_x) extended by their end values."""
        return [self.fft.rfft(np.concatenate([np.repeat(rows[:, :1], left, 1), rows,
                                               np.repeat(rows[:, -1:], right, 1)], 1), n=n, axis=1)
                for (left, right), n in zip(self.pads, self.lengths)]

    def __call__(self, row_spectra: np.ndarray, feed_index: int) -> np.ndarray:
        """E[J(X - delta)] for each (row, force of the feed, state): (rows, forces, n_x), from
        this feed's spectra of the rows."""
        full = self.fft.irfft(row_spectra[:, None, :] * self.kernel_spectra[feed_index][None],
                               n=self.lengths[feed_index], axis=2)
        first = self.first[feed_index]
        return full[:, :, first:first + self.n_x]


@dataclass
class Policy:
    """Tables over (time stage, material state) and the run-time lookup.

    ``action`` WAIT/GRIND/QUIT; ``force_n``, ``feed_mm_s``, ``pass_duration_s``, ``cut_mm`` (mean
    cut depth) NaN where not grinding; ``penalty`` is J*; ``cut_fraction`` = mean delta / X.
    """

    time_s: np.ndarray
    material_mm: np.ndarray
    action: np.ndarray
    force_n: np.ndarray
    feed_mm_s: np.ndarray
    pass_duration_s: np.ndarray
    cut_mm: np.ndarray
    penalty: np.ndarray
    metadata: dict

    @property
    def cut_fraction(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.material_mm > 0, self.cut_mm / self.material_mm, np.nan)

    def stage_index(self, time_remaining_s: float) -> int:
        """The stage at or below t: less time than there is, so a planned pass ends in time."""
        dt = self.time_s[1] - self.time_s[0]
        return int(np.clip(math.floor((time_remaining_s - self.time_s[0]) / dt + 1e-9), 0, len(self.time_s) - 1))

    def expected_penalty(self, time_remaining_s: float, material_mm: float) -> float:
        """J* at (t, X), linear in X on the stage at or below t."""
        return float(np.interp(material_mm, self.material_mm, self.penalty[self.stage_index(time_remaining_s)]))

    def lookup(self, time_remaining_s: float, material_mm: float) -> dict:
        """The decision at a measured state (feedback from the table, thesis Fig. 5-7).

        Between two material nodes that both grind with the same feed, the force is
        interpolated linearly; otherwise the nearer node decides.
        """
        if not (math.isfinite(time_remaining_s) and math.isfinite(material_mm)):
            raise ValueError("time and material remaining must be finite")
        k = self.stage_index(time_remaining_s)
        x = self.material_mm
        i = int(np.clip(np.searchsorted(x, material_mm) - 1, 0, len(x) - 2))
        w = float(np.clip((material_mm - x[i]) / (x[i + 1] - x[i]), 0.0, 1.0))
        near = i if w < 0.5 else i + 1
        action = int(self.action[k, near])
        force, feed = self.force_n[k, near], self.feed_mm_s[k, near]
        if (action == GRIND and self.action[k, i] == GRIND and self.action[k, i + 1] == GRIND
                and self.feed_mm_s[k, i] == self.feed_mm_s[k, i + 1]):
            force = (1 - w) * self.force_n[k, i] + w * self.force_n[k, i + 1]
        return {"action": ACTION_NAMES[action], "force_n": float(force), "feed_mm_s": float(feed),
                "duration_s": float(self.pass_duration_s[k, near]), "stage_time_s": float(self.time_s[k]),
                "expected_penalty": self.expected_penalty(time_remaining_s, material_mm)}

    def save(self, path) -> None:
        arrays = {name: getattr(self, name) for name in
                  ("time_s", "material_mm", "action", "force_n", "feed_mm_s", "pass_duration_s", "cut_mm", "penalty")}
        np.savez_compressed(path, metadata=json.dumps(self.metadata), **arrays)

    @classmethod
    def load(cls, path) -> Policy:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files if name != "metadata"}
            return cls(metadata=json.loads(str(data["metadata"])), **arrays)


def solve(process: GrindingProcess, charges: Charges = Charges(), grid: PlannerGrid = PlannerGrid(),
          cut_model: CutDepthModel = CutDepthModel(), progress=None) -> Policy:
    """Backward induction over the whole grid; returns the optimal policy.

    ``progress`` (optional) is called with the number of stages done after each block.
    """
    x = grid.material_mm
    times = grid.time_s
    n_x, n_t = len(x), len(times)
    controls = build_controls(process, grid, cut_model)
    late = grid.late_horizon_s > 0
    deadline_charge = charges.deadline(x)

    correlation = CutCorrelation.of(controls, cut_model, grid.material_step_mm, n_x)
    durations = [int(d) for d in controls.duration_stages]
    finish = charges.in_path.surface_finish_per_mm_s

    penalty = np.empty((n_t, n_x))
    no_grind_after = np.empty((n_t, n_x))
    penalty_spectra = correlation.empty_spectra(n_t)  # per feed
    no_grind_spectra = correlation.empty_spectra(n_t) if finish > 0 else None
    action = np.full((n_t, n_x), WAIT, np.int8)
    best_force = np.full((n_t, n_x), np.nan)
    best_feed_index = np.full((n_t, n_x), -1)

    def transform(rows):  # the spectra of finished stages, for the stages that land on them
        _store(penalty_spectra, rows, correlation.spectra(penalty[rows]))
        if finish > 0:
            _store(no_grind_spectra, rows, correlation.spectra(no_grind_after[rows]))

    def quit_value(k):
        return deadline_charge + (charges.lateness(-times[k]) if late else 0.0)

    has_material = x > charges.deadline.tolerance_mm
    penalty[0] = quit_value(0)
    action[0] = QUIT if late else WAIT
    no_grind_after[0] = 1.0
    transform([0])
    block = int(controls.duration_stages.min())
    k = 1
    while k < n_t:
        stages = np.arange(k, min(k + block, n_t))
        grind = np.full((len(stages), n_x), np.inf)
        grind_force = np.zeros((len(stages), n_x), int)
        grind_feed = np.full((len(stages), n_x), -1)
        for v, duration in enumerate(durations):
            valid = stages - duration >= 0
            feasible = controls.feasible[:, v]
            if not valid.any() or not feasible.any():
                continue
            targets = stages[valid] - duration
            expected = correlation(penalty_spectra[v][targets], v)  # (stages, feasible forces, n_x)
            if finish > 0:
                expected += finish * controls.feeds_mm_s[v] * correlation(no_grind_spectra[v][targets], v)
            # below the transforms' rounding the order of two controls is noise: of those
            # within it of the best, the lowest force and the fastest feed (the first)
            rounding = ROUNDING * max(1.0, np.abs(penalty[targets]).max() + finish * controls.feeds_mm_s[v])
            f_best = np.argmax(expected <= expected.min(axis=1, keepdims=True) + rounding, axis=1)
            value = np.take_along_axis(expected, f_best[:, None, :], axis=1)[:, 0, :] + charges.in_path.per_pass
            better = value < grind[valid] - rounding
            rows = np.flatnonzero(valid)
            grind[rows] = np.where(better, value, grind[rows])
            grind_force[rows] = np.where(better, np.flatnonzero(feasible)[f_best], grind_force[rows])
            grind_feed[rows] = np.where(better, v, grind_feed[rows])
        for row, stage in enumerate(stages):
            # not grinding: wait a stage before the deadline, quit after it (or quit anywhere)
            rest = penalty[stage - 1] if times[stage] > 0 else np.full(n_x, np.inf)
            stop = quit_value(stage) if late else np.full(n_x, np.inf)
            idle_choice = np.where(stop <= rest, QUIT, WAIT) if late else np.full(n_x, WAIT)
            idle = np.minimum(rest, stop)
            # ties (to rounding): grind while material remains above the tolerance band --
            # as good, and earlier -- but never when there is nothing to remove
            tie = 1e-12 * np.maximum(1.0, np.abs(idle))
            grinds = np.where(has_material, grind[row] <= idle + tie, grind[row] < idle - tie)
            penalty[stage] = np.where(grinds, grind[row], idle)
            action[stage] = np.where(grinds, GRIND, idle_choice)
            no_grind_after[stage] = np.where(grinds, 0.0, 1.0)
            best_force[stage] = np.where(grinds, controls.forces_n[grind_force[row]], np.nan)
            best_feed_index[stage] = np.where(grinds, grind_feed[row], -1)
        transform(stages)
        k = stages[-1] + 1
        if progress is not None:
            progress(len(stages))

    grinding = best_feed_index >= 0
    feed_index = np.where(grinding, best_feed_index, 0)
    feed = np.where(grinding, controls.feeds_mm_s[feed_index], np.nan)
    duration = np.where(grinding, controls.duration_stages[feed_index] * grid.time_step_s, np.nan)
    cut = np.where(grinding, process.cut_depth_mm(np.nan_to_num(best_force), np.where(grinding, feed, 1.0)), np.nan)
    metadata = {"process": process.to_dict(), "grid": asdict(grid), "cut_model": asdict(cut_model),
                "charges": {"deadline": asdict(charges.deadline), "lateness": asdict(charges.lateness),
                            "in_path": asdict(charges.in_path)},
                "feeds_mm_s": controls.feeds_mm_s.tolist(), "forces_n": controls.forces_n.tolist()}
    return Policy(times, x, action, best_force, feed, duration, cut, penalty, metadata)


def feed_values(policy: Policy, controls: Controls, cut_model: CutDepthModel, time_remaining_s: float,
                material_mm: float, *, force_index: int = -1) -> np.ndarray:
    """E[J*] after one pass from the node at (t, X) with the force ``controls.forces_n[force_index]``,
    per feed (NaN where the pass does not fit or is infeasible), before the per-pass charge: how
    much the planner cares which feed it takes there."""
    k, i = policy.stage_index(time_remaining_s), int(np.argmin(np.abs(policy.material_mm - material_mm)))
    step = float(policy.material_mm[1] - policy.material_mm[0])
    values = np.full(len(controls.feeds_mm_s), np.nan)
    for v, duration in enumerate(controls.duration_stages):
        if k - duration < 0 or not controls.feasible[force_index, v]:
            continue
        mean, std = controls.mean_cut_mm[force_index, v], controls.cut_std_mm[force_index, v]
        offsets = transition_offsets(cut_model, mean, std, step)
        landing = policy.penalty[k - duration][np.clip(i - offsets, 0, len(policy.material_mm) - 1)]
        values[v] = transition_weights(cut_model, mean, std, step, offsets) @ landing
    return values


def _store(per_feed: list[np.ndarray], rows, spectra: list[np.ndarray]) -> None:
    for table, values in zip(per_feed, spectra):
        table[rows] = values
