"""Tables (terminal, Markdown, CSV), claims with verdicts, and the Markdown report."""
import csv
import io
import math
import os

from .stats import format_p


class Est(object):
    """An estimate with its 95% confidence interval: "m ± h" in text (or "m [lo, hi]" for an
    asymmetric interval such as Wilson's), three CSV columns (value, ci95 lo, ci95 hi)."""

    def __init__(self, mean, half, fmt="%.2f", lo=None, hi=None):
        self.mean, self.half, self.fmt = float(mean), float(half), fmt
        self.asymmetric = lo is not None
        self.lo = float(lo) if lo is not None else self.mean - self.half
        self.hi = float(hi) if hi is not None else self.mean + self.half

    @classmethod
    def of(cls, estimate, fmt="%.2f", asymmetric=False):
        """From a stats.Estimate (asymmetric: show its lo/hi, e.g. Wilson intervals)."""
        if asymmetric:
            return cls(estimate.mean, estimate.half, fmt, estimate.lo, estimate.hi)
        return cls(estimate.mean, estimate.half, fmt)

    def text(self):
        if math.isnan(self.half):
            return self.fmt % self.mean
        if self.asymmetric:
            return (self.fmt + " [" + self.fmt + ", " + self.fmt + "]") % (
                self.mean, self.lo, self.hi)
        return (self.fmt + " ± " + self.fmt) % (self.mean, self.half)


class P(object):
    """A p-value cell (printed as the paper does)."""

    def __init__(self, p):
        self.p = float(p)

    def text(self):
        return format_p(self.p)


def _num(v):
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else "%.10g" % v


class Table(object):
    """A result table. Cells are str, int, float (shown with the column's format, default
    %.3f), Est or P. `name` is the file stem of its .md/.csv files."""

    def __init__(self, name, title, columns, rows, formats=None, note=None):
        self.name, self.title, self.columns, self.rows = name, title, list(columns), rows
        self.formats = dict(formats or {})
        self.note = note
        for r in rows:
            if len(r) != len(self.columns):
                raise ValueError("table %s: row %r has %d cells for %d columns"
                                 % (name, r, len(r), len(self.columns)))

    def _cell(self, col, v):
        if v is None:
            return ""
        if isinstance(v, (Est, P)):
            return v.text()
        if isinstance(v, float):
            return "n/a" if math.isnan(v) else self.formats.get(col, "%.3f") % v
        return str(v)

    def cells(self):
        return [[self._cell(c, v) for c, v in zip(self.columns, r)] for r in self.rows]

    def text(self):
        """Aligned plain-text rendering for the terminal."""
        body = self.cells()
        widths = [max([len(c)] + [len(r[i]) for r in body]) for i, c in enumerate(self.columns)]
        # text columns left-aligned, numeric ones right-aligned
        left = [any(isinstance(r[i], str) and len(r[i]) > 12 for r in self.rows)
                for i in range(len(self.columns))]
        line = lambda cells: "  ".join(  # noqa: E731
            (s.ljust(w) if lf else s.rjust(w)) for s, w, lf in zip(cells, widths, left)).rstrip()
        out = [self.title, line(self.columns), "  ".join("-" * w for w in widths)]
        out += [line(r) for r in body]
        if self.note:
            out.append(self.note)
        return "\n".join(out)

    def markdown(self):
        out = ["**%s**" % self.title, "", "| " + " | ".join(self.columns) + " |",
               "|" + "---|" * len(self.columns)]
        out += ["| " + " | ".join(r) + " |" for r in self.cells()]
        if self.note:
            out += ["", self.note]
        return "\n".join(out)

    def csv_text(self):
        """CSV with full precision; an Est column becomes two (value, "value ci95")."""
        est_cols = {c for i, c in enumerate(self.columns)
                    if any(isinstance(r[i], Est) for r in self.rows)}
        header = []
        for c in self.columns:
            header += [c, c + " ci95 lo", c + " ci95 hi"] if c in est_cols else [c]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(header)
        for r in self.rows:
            out = []
            for c, v in zip(self.columns, r):
                if isinstance(v, Est):
                    cell = [_num(v.mean), _num(v.lo), _num(v.hi)]
                elif isinstance(v, P):
                    cell = [_num(v.p)]
                elif isinstance(v, float) or (isinstance(v, int) and not isinstance(v, bool)):
                    cell = [_num(v)]
                else:
                    cell = ["" if v is None else str(v)]
                out += cell + (["", ""] if c in est_cols and not isinstance(v, Est) else [])
            w.writerow(out)
        return buf.getvalue()

    def save(self, out_dir):
        """Write <name>.md and <name>.csv into out_dir; returns their paths."""
        md, cs = os.path.join(out_dir, self.name + ".md"), os.path.join(out_dir, self.name + ".csv")
        with open(md, "w") as f:
            f.write(self.markdown() + "\n")
        with open(cs, "w", newline="") as f:
            f.write(self.csv_text())
        return md, cs


SUPPORTED = "supported"


def verdict(direction_ok, p=None, alpha=0.05):
    """'supported' if the effect has the paper's direction and (when tested, p given)
    p < alpha; otherwise 'NOT supported' with the reason for tested claims."""
    if p is None:
        return SUPPORTED if direction_ok else "NOT supported"
    if not direction_ok:
        return "NOT supported (opposite direction)"
    if math.isnan(p) or p >= alpha:
        return "NOT supported (right direction, not significant: p = %s)" % format_p(p)
    return SUPPORTED


class Claim(object):
    """One claim of the paper, our evidence, and the verdict."""

    def __init__(self, experiment, claim, paper, ours, direction_ok, p=None, alpha=0.05,
                 too_few=None, reason=None):
        """reason: for a claim this run does not support, one or two sentences, generated
        from the measured numbers, saying why (shown with the claim in report.md)."""
        self.experiment, self.claim, self.paper, self.ours = experiment, claim, paper, ours
        self.reason, self.alpha, self.too_few = reason, alpha, too_few
        self.direction_ok, self.p = bool(direction_ok), p
        self.verdict = verdict(direction_ok, p, alpha)
        if too_few:
            self.direction_ok, self.p = False, None
            self.verdict = "NOT supported (too few data: %s)" % too_few
            if not self.reason:
                self.reason = "Too few data to test it: %s." % too_few

    def generic_reason(self):
        """The fallback reason of an unsupported claim whose experiment gave none: what the
        verdict rests on, from the claim's own numbers."""
        if self.supported:
            return None
        if self.too_few:
            return "Too few data to test it: %s." % self.too_few
        if self.p is not None and self.direction_ok:
            return ("The effect has the paper's direction but is not significant at this trial "
                    "count (p = %s >= %g): %s." % (format_p(self.p), self.alpha, self.ours))
        if self.p is not None:
            return "The measured effect has the opposite direction: %s." % self.ours
        return "Measured: %s." % self.ours

    def why(self):
        """Why an unsupported claim is not supported (the experiment's reason, else the generic
        one); None for a supported claim."""
        if self.supported:
            return None
        return self.reason or self.generic_reason()

    @classmethod
    def too_few_data(cls, experiment, claim, paper, what):
        """A claim that could not be tested (e.g. fewer than two samples in a group)."""
        return cls(experiment, claim, paper, what, False, too_few=what)

    @property
    def supported(self):
        return self.verdict == SUPPORTED

    def as_dict(self):
        return {"experiment": self.experiment, "claim": self.claim, "paper": self.paper,
                "ours": self.ours, "direction_ok": self.direction_ok,
                "p": None if self.p is None else float(self.p), "verdict": self.verdict,
                "reason": self.why(),
                "reason_source": None if self.supported else
                ("experiment" if self.reason else "generic")}


def claims_table(claims):
    """All claims as one table (one line per claim)."""
    rows = [[i + 1, c.experiment, c.claim, c.paper, c.ours, c.verdict]
            for i, c in enumerate(claims)]
    return Table("claims", "Claims of the paper and whether this run supports them",
                 ["#", "experiment", "paper's claim", "paper", "ours", "verdict"], rows)


class Result(object):
    """What an experiment produced: tables, figures (file names in the output folder),
    claims, notes (Markdown lines) and the parameters it ran with."""

    def __init__(self, key, title):
        self.key, self.title = key, title
        self.tables, self.figures, self.claims, self.notes = [], [], [], []
        self.seconds = None


def write_report(path, header_lines, results, times, cpu=None):
    """The Markdown report: claims at a glance, then every experiment's tables and figures,
    then the time per experiment."""
    claims = [c for r in results for c in r.claims]
    n_ok = sum(c.supported for c in claims)
    out = list(header_lines)
    out += ["", "## Claims at a glance", "",
            "%d of %d claims supported (direction as in the paper and, where tested, p < alpha)."
            % (n_ok, len(claims)), "", claims_table(claims).markdown(), ""]
    unsupported = [(i + 1, c) for i, c in enumerate(claims) if not c.supported]
    if unsupported:
        out += ["### Why claims are not supported", ""]
        out += ["Each reason is generated from this run's numbers.", ""]
        out += ["- **#%d %s** (%s; %s): %s" % (i, c.claim, c.experiment, c.verdict, c.why())
                for i, c in unsupported]
        out += [""]
    for r in results:
        out += ["## %s" % r.title, ""]
        for note in r.notes:  # one paragraph each
            out += [note, ""]
        for t in r.tables:
            out += [t.markdown(), "", "(`%s.csv`, `%s.md`)" % (t.name, t.name), ""]
        for f in r.figures:
            out += ["![%s](%s)" % (f, f), ""]
    if times:
        cpu = cpu or {}
        out += ["## Time per experiment", "", "| experiment | wall s | CPU s |", "|---|---|---|"]
        out += ["| %s | %.1f | %s |" % (k, v, "%.1f" % cpu[k] if k in cpu else "")
                for k, v in times.items()]
        out += ["", "CPU: this process and its CLI processes (not counted on a Dask cluster).",
                ""]
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")
