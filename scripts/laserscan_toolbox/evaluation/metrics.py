"""Scan quality metrics against an ideal (ground-truth) scan. Pure numpy.

Both scans are arrays of ranges over the same beams (same angle_min, angle_increment).
REP 117: +Inf = no return, -Inf = too close, NaN = invalid; only finite, positive ranges
are obstacles.

Definitions (documented in docs/tools.md, used by evaluate_bag and the tests):
- range error: |output - ideal| on beams where both see something. With
  ``beam_window`` k > 0 the error of beam i is the smallest |output_i - ideal_j| for
  j in [i-k, i+k], so an obstacle edge that falls one beam off is not counted as a
  metre-sized error.
- false obstacle: the output has a return r on beam i while the ideal scan has nothing
  at or before r + tol(r) on beams i-k..i+k (the output claims free space is blocked).
- missed obstacle: the ideal scan has an obstacle at d <= range_max on beam i while the
  output has nothing at or before d + tol(d) on beams i-k..i+k. Only beams in ``mask``
  count (e.g. a camera's field of view).
- tol(r) = tol + rel_tol * r: sensors' range noise grows with range (depth cameras
  roughly with its square), and a closest-point scan is biased short by that noise; a
  phantom floor, ceiling or ghost is off by far more. Give the ideal scan a little more
  range than the output (range_max + tol(range_max)) so a wall just beyond range_max
  that noise brings inside is not a false obstacle.
- coverage: fraction of beams in ``mask`` with a return in the output.
"""

from dataclasses import dataclass

import numpy as np


def is_return(ranges):
    r = np.asarray(ranges, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r > 0.0)


def _window_stack(values, k, fill):
    """Rows are values shifted by -k..k (edges filled with ``fill``); shape (2k+1, n)."""
    n = values.shape[-1]
    out = np.full((2 * k + 1, n), fill, dtype=float)
    for row, s in enumerate(range(-k, k + 1)):
        if s < 0:
            out[row, -s:] = values[: n + s]
        elif s > 0:
            out[row, : n - s] = values[s:]
        else:
            out[row] = values
    return out


@dataclass
class ScanComparison:
    """One scan against its ideal scan (``compare_scan``), counted over the beams in the mask."""
    errors: np.ndarray  # range error of each beam where both see something, m
    beams: int
    returns: int  # output returns
    ideal_returns: int  # ideal returns within range_max
    false: int  # false obstacles
    missed: int  # missed obstacles

    def summary(self):
        return summarize(self.errors, self.beams, self.returns, self.ideal_returns, self.false,
                         self.missed)


class ScanStats:
    """Accumulates per-beam outcomes over many scans of one topic."""

    def __init__(self):
        self.errors = []
        self.beams = 0
        self.returns = 0
        self.ideal_returns = 0
        self.false = 0
        self.missed = 0
        self.scans = 0

    def add(self, result):
        """Adds one ``ScanComparison``."""
        self.errors.append(result.errors)
        self.beams += result.beams
        self.returns += result.returns
        self.ideal_returns += result.ideal_returns
        self.false += result.false
        self.missed += result.missed
        self.scans += 1

    def summary(self):
        err = np.concatenate(self.errors) if self.errors else np.zeros(0)
        return summarize(err, self.beams, self.returns, self.ideal_returns, self.false,
                         self.missed, self.scans)


def summarize(errors, beams, returns, ideal_returns, false, missed, scans=1):
    errors = np.asarray(errors, dtype=float)
    return {
        "scans": int(scans),
        "beams": int(beams),
        "compared": int(errors.size),
        "median_error": float(np.median(errors)) if errors.size else float("nan"),
        "p95_error": float(np.percentile(errors, 95)) if errors.size else float("nan"),
        "mean_error": float(np.mean(errors)) if errors.size else float("nan"),
        # false obstacles per output return, missed obstacles per ideal return
        "false_rate": false / returns if returns else 0.0,
        "missed_rate": missed / ideal_returns if ideal_returns else 0.0,
        "false": int(false),
        "missed": int(missed),
        "returns": int(returns),
        "ideal_returns": int(ideal_returns),
        "coverage": returns / beams if beams else 0.0,
    }


def compare_scan(output, ideal, tol=0.05, beam_window=1, mask=None, rel_tol=0.0,
                 range_max=np.inf):
    """Per-scan outcomes of ``output`` against ``ideal`` (see module docstring): a
    ``ScanComparison``, which ``summarize`` / ``ScanStats`` turn into figures.
    """
    out = np.asarray(output, dtype=float)
    ide = np.asarray(ideal, dtype=float)
    if out.shape != ide.shape or out.ndim != 1:
        raise ValueError("output and ideal must be 1-D arrays of the same length "
                         "(got %s and %s)" % (out.shape, ide.shape))
    if tol < 0 or beam_window < 0 or rel_tol < 0:
        raise ValueError("tol, rel_tol and beam_window must be >= 0")
    m = np.ones(out.shape, bool) if mask is None else np.asarray(mask, bool)
    if m.shape != out.shape:
        raise ValueError("mask must have the scan's length")
    k = int(beam_window)
    out_ret = is_return(out)
    ide_ret = is_return(ide)
    out_v = np.where(out_ret, out, np.inf)
    ide_v = np.where(ide_ret, ide, np.inf)
    ide_win = _window_stack(ide_v, k, np.inf)  # ideal ranges near each beam
    out_win = _window_stack(out_v, k, np.inf)

    both = out_ret & ide_ret & m
    with np.errstate(invalid="ignore"):
        err_all = np.min(np.abs(ide_win - out_v[None, :]), axis=0)
    errors = err_all[both]

    nearest_ideal = np.min(ide_win, axis=0)
    nearest_out = np.min(out_win, axis=0)
    with np.errstate(invalid="ignore"):  # 0 * inf on beams without a return, masked below
        false = out_ret & m & ~(nearest_ideal <= out_v + tol + rel_tol * out_v)
        in_range = ide_ret & (ide_v <= range_max)
        missed = in_range & m & ~(nearest_out <= ide_v + tol + rel_tol * ide_v)
    return ScanComparison(errors=errors, beams=int(m.sum()), returns=int((out_ret & m).sum()),
                          ideal_returns=int((in_range & m).sum()), false=int(false.sum()),
                          missed=int(missed.sum()))


def scan_metrics(output, ideal, tol=0.05, beam_window=1, mask=None, rel_tol=0.0,
                 range_max=np.inf):
    """Figures for one scan (median / p95 error, false / missed rates, coverage)."""
    return compare_scan(output, ideal, tol, beam_window, mask, rel_tol, range_max).summary()


def angular_mask(n, angle_min, angle_increment, lo, hi):
    """Beams whose angle lies in [lo, hi] (wrapping around +-pi when lo > hi)."""
    a = angle_min + angle_increment * np.arange(n)
    a = np.arctan2(np.sin(a), np.cos(a))
    if lo <= hi:
        return (a >= lo) & (a <= hi)
    return (a >= lo) | (a <= hi)


def rate_stats(stamps):
    """Rate (Hz) from message stamps (s) and the largest gap between two messages."""
    s = np.sort(np.asarray(stamps, dtype=float))
    if s.size < 2 or s[-1] <= s[0]:
        return {"count": int(s.size), "rate": float("nan"), "max_gap": float("nan")}
    return {"count": int(s.size), "rate": float((s.size - 1) / (s[-1] - s[0])),
            "max_gap": float(np.max(np.diff(s)))}


def latency_stats(receive_times, stamps):
    """Receipt time minus stamp (s): median, p95, min, max, and the fraction below zero
    (stamps ahead of the receiving clock). Pairs with a missing value are left out."""
    with np.errstate(invalid="ignore"):
        d = np.asarray(receive_times, float) - np.asarray(stamps, float)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return {"median": float("nan"), "p95": float("nan"), "max": float("nan"),
                "min": float("nan"), "negative_fraction": float("nan")}
    return {"median": float(np.median(d)), "p95": float(np.percentile(d, 95)),
            "max": float(np.max(d)), "min": float(np.min(d)),
            "negative_fraction": float(np.mean(d < 0))}


def grid_iou(a, b, region=None):
    """Intersection over union of two boolean grids, optionally inside ``region``."""
    a = np.asarray(a, bool)
    b = np.asarray(b, bool)
    if a.shape != b.shape:
        raise ValueError("grids differ in shape: %s vs %s" % (a.shape, b.shape))
    if region is not None:
        a = a & region
        b = b & region
    union = np.count_nonzero(a | b)
    return np.count_nonzero(a & b) / union if union else float("nan")


def glass_beams(ideal, ideal_without_glass, tol=0.05, max_range=np.inf):
    """Beams whose closest obstacle is glass: the ideal scan with glass panes has a return
    within ``max_range`` that is closer (by more than ``tol``) than without them."""
    with_glass = np.asarray(ideal, float)
    without = np.asarray(ideal_without_glass, float)
    with np.errstate(invalid="ignore"):
        return is_return(with_glass) & (with_glass <= max_range) & ~(without <= with_glass + tol)


def glass_found(output, ideal, glass, tol=0.05, rel_tol=0.0):
    """(glass beams, beams where the output has an obstacle at or before the glass + tol):
    a robot that stops there does not drive into the pane."""
    out = np.asarray(output, float)
    d = np.asarray(ideal, float)
    with np.errstate(invalid="ignore"):
        found = is_return(out) & (out <= d + tol + rel_tol * d)
    return int(np.sum(glass)), int(np.sum(found & glass))
