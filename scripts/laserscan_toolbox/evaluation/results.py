"""What the evaluation's steps hand each other: one typed result, written to results.json in
one place (``EvaluationResult.to_json``) and read back from it (``from_json``).

A step that did not run is a ``NotRun`` with its reason (skipped: nothing to run it on;
failed: it ran and broke), never a dict that holds a "skipped" or "error" key; ``ran(step)``
tells the two apart. The figures of a step (an output's rate and latency, a topic's accuracy,
a map's IoU, an OctoMap run) stay the JSON-shaped dicts that results.json holds key for key
(docs/tools.md lists its keys; machines read them), so that the JSON is the same as before the
types. Only this module knows how a NotRun or the SLAM experiment is spelt in JSON.
"""

from dataclasses import dataclass, field, fields
from typing import Dict, List, Optional, Union


@dataclass(frozen=True)
class NotRun:
    """A step of the evaluation that did not run, and why."""
    reason: str
    failed: bool = False  # True: it ran and broke ("error" in JSON); else skipped

    def to_json(self):
        return {"error" if self.failed else "skipped": self.reason}

    @staticmethod
    def from_json(value):
        """The NotRun a JSON value spells, or None when it holds figures (which never have a
        "skipped" or "error" key; a results.json of before the types could hold a bag input's
        "input" flag beside "skipped")."""
        if isinstance(value, dict):
            for key in ("skipped", "error"):
                if isinstance(value.get(key), str):
                    return NotRun(value[key], failed=key == "error")
        return None


def ran(step):
    """True when a step's value holds figures: neither None (not asked for) nor NotRun."""
    return step is not None and not isinstance(step, NotRun)


@dataclass(frozen=True)
class Check:
    """One threshold or target and whether the run met it."""
    ok: bool
    check: str

    def to_json(self):
        return {"ok": self.ok, "check": self.check}


@dataclass
class SlamRun:
    """The SLAM and localization experiment (``slam.slam_experiment``): figures per topic and
    the experiment's settings. results.json spells it as three entries: "slam",
    "localization" (when localization ran) and "slam_experiment" (the rest)."""
    slam: Dict[str, dict]
    localization: Optional[Dict[str, dict]]
    figures: Dict[str, str]
    min_interval_s: float
    seed: int
    tolerance_m: float

    def settings_json(self):
        return {"figures": self.figures, "min_interval_s": self.min_interval_s,
                "seed": self.seed, "tolerance_m": self.tolerance_m}


#: A step's value: its figures, NotRun, or None when it was not asked for (no key in the JSON).
Step = Union[dict, NotRun, None]


@dataclass
class EvaluationResult:
    """Everything ``evaluate`` measured; the field names are results.json's keys. Fields that
    default to None are left out of the JSON when None (the step was not asked for, or the bag
    has no ground truth); the others are always written."""
    bag: str = ""
    bag_duration_s: float = 0.0
    bag_size_bytes: int = 0
    launch: List[str] = field(default_factory=list)
    player: List[str] = field(default_factory=list)
    ground_truth: bool = False
    inputs: Dict[str, dict] = field(default_factory=dict)
    outputs: Dict[str, dict] = field(default_factory=dict)
    cpu: Dict[str, dict] = field(default_factory=dict)
    cpu_summary: dict = field(default_factory=dict)
    cpu_whole_playback_sim_clock: Dict[str, dict] = field(default_factory=dict)
    playback_wall_s: float = 0.0
    unrecorded_outputs: Dict[str, str] = field(default_factory=dict)
    # with ground truth
    band: Optional[List[float]] = None
    accuracy: Optional[Dict[str, Union[dict, NotRun]]] = None  # per topic
    glass: Optional[Dict[str, dict]] = None
    self_filter: Optional[Dict[str, dict]] = None
    mapping: Step = None
    slam: Union[SlamRun, NotRun, None] = None
    octomap: Step = None
    # without ground truth
    scan_plot: Optional[dict] = None
    # added by scripts/demo: the closed-loop navigation run (scripts/navigation_experiment)
    navigation: Optional[dict] = None
    thresholds: List[Check] = field(default_factory=list)
    passed: bool = False
    evaluation_wall_s: float = 0.0

    def to_json(self):
        """The results.json dict (numpy values are left to report.write_json)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None and f.default is None:
                continue
            if f.name == "slam":
                out.update(_slam_json(value))
            else:
                out[f.name] = _json(value)
        return out

    @classmethod
    def from_json(cls, data):
        """The result a results.json dict spells (TypeError naming an unknown key)."""
        kw = dict(data)
        slam, loc = kw.pop("slam", None), kw.pop("localization", None)
        experiment = kw.pop("slam_experiment", None)
        if experiment is not None:
            kw["slam"] = NotRun.from_json(experiment) or SlamRun(
                slam=slam or {}, localization=loc, **experiment)
        for name in ("mapping", "octomap"):
            if name in kw:
                kw[name] = NotRun.from_json(kw[name]) or kw[name]
        if kw.get("accuracy") is not None:
            kw["accuracy"] = {t: NotRun.from_json(a) or a for t, a in kw["accuracy"].items()}
        kw["thresholds"] = [Check(**c) for c in kw.get("thresholds", [])]
        return cls(**kw)

    # Figures of ran steps, empty when a step did not run: what reports and checks iterate.
    def accuracy_figures(self):
        """{topic: figures} of the topics judged against the ground truth."""
        return {t: a for t, a in (self.accuracy or {}).items() if ran(a)}

    def slam_figures(self):
        return slam_figures(self.slam)


def slam_figures(step):
    """(slam, localization) of a SLAM step: {topic: figures} each, empty when it did not run."""
    if not ran(step):
        return {}, {}
    return step.slam, step.localization or {}


def _slam_json(value):
    if isinstance(value, NotRun):
        return {"slam_experiment": value.to_json()}
    out = {"slam": _json(value.slam)}
    if value.localization is not None:
        out["localization"] = _json(value.localization)
    out["slam_experiment"] = _json(value.settings_json())
    return out


def _json(value):
    if isinstance(value, (NotRun, Check)):
        return value.to_json()
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json(v) for v in value]
    return value
