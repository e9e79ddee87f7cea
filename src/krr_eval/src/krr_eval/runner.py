"""Run independent trials of the core CLIs in parallel, deterministically.

A `TrialSpec` names a CLI, its experiment options, a seed and a number of trials. `Runner.run`
splits each spec's trials [0, N) into chunks, runs one CLI process per chunk on a local pool
of `workers` slots (each CLI process is single-threaded: `--threads 1`) or on a Dask
distributed cluster (`scheduler="tcp://host:port"`), checks every chunk returned exactly its
trial indices under the same header, and concatenates the rows in trial order. Since trial i
depends only on (seed, i), the table is byte-identical for any number of workers, any chunk
size, and for Dask vs local runs.

Tables are saved as `<record_dir>/trials/<name>.csv` with a record (program, options, seed,
trials, sha256) in `Runner.records`; with `replay_dir` the runner reads those CSVs instead of
running anything (`--replay`).
"""
import collections
import concurrent.futures
import hashlib
import json
import math
import os
import sys
import threading
import time

from . import chunk as chunk_mod
from . import paths
from .trials import TrialTable


class TrialSpec(collections.namedtuple(
        "TrialSpec", "name program args seed trials trials_flag scratch_flags min_chunk cost")):
    """One set of trials: `name` (file stem, unique in a run), CLI `program`, its `args`,
    `seed`, number of `trials`, the option taking the per-trial CSV (`trials_flag`),
    options that need a throwaway output path (`scratch_flags`), the smallest chunk worth
    a process (`min_chunk`: for CLIs whose start-up costs more than many trials) and the
    relative CPU cost of one trial (`cost`, for splitting and ordering chunks so the workers
    finish together). min_chunk and cost change only the speed, never the table."""

    def __new__(cls, name, program, args, seed, trials, trials_flag="--out", scratch_flags=(),
                min_chunk=1, cost=1.0):
        if not name or "/" in name or name.startswith("."):
            raise ValueError("trial set name %r must be a plain file stem" % (name,))
        if int(trials) != trials or trials < 1:
            raise ValueError("%s: trials must be a positive integer, got %r" % (name, trials))
        if int(min_chunk) != min_chunk or min_chunk < 1:
            raise ValueError("%s: min_chunk must be a positive integer" % name)
        if not float(cost) > 0:
            raise ValueError("%s: cost must be positive, got %r" % (name, cost))
        return super(TrialSpec, cls).__new__(
            cls, name, program, tuple(str(a) for a in args), int(seed), int(trials),
            trials_flag, tuple(scratch_flags), int(min_chunk), float(cost))

    def key(self):
        """What determines the table: everything but the name, as a JSON-able dict."""
        return {"program": self.program, "args": list(self.args), "seed": self.seed,
                "trials": self.trials, "trials_flag": self.trials_flag}


def split(n, chunks):
    """Split [0, n) into `chunks` contiguous (begin, count) ranges of near-equal size."""
    if n < 1 or chunks < 1:
        raise ValueError("split needs n >= 1 and chunks >= 1 (got %r, %r)" % (n, chunks))
    chunks = min(chunks, n)
    base, extra = divmod(n, chunks)
    out, begin = [], 0
    for c in range(chunks):
        count = base + (1 if c < extra else 0)
        out.append((begin, count))
        begin += count
    return out


def assemble(spec, parts):
    """Concatenate chunk CSV texts [(begin, count, text)] into one TrialTable in trial order.

    Every chunk must have the same header and contain exactly the trial indices of its range
    (one or more rows each); rows keep their order within a trial."""
    header, rows = None, []
    for begin, count, text in sorted(parts, key=lambda p: p[0]):
        src = "%s trials %d..%d" % (spec.program, begin, begin + count - 1)
        t = TrialTable.from_text(text, src)
        if header is None:
            header = t.header
        elif t.header != header:
            raise ValueError("%s: header %s differs from the first chunk's %s"
                             % (src, t.header, header))
        idx = t.trial_indices()
        if set(idx) != set(range(begin, begin + count)):
            missing = sorted(set(range(begin, begin + count)) - set(idx))[:5]
            extra = sorted(set(idx) - set(range(begin, begin + count)))[:5]
            raise ValueError("%s: first column '%s' must hold trial indices %d..%d (missing %s, "
                             "unexpected %s)" % (src, t.header[0], begin, begin + count - 1,
                                                 missing, extra))
        order = sorted(range(len(idx)), key=lambda k: idx[k])  # stable within a trial
        rows.extend(t.rows[k] for k in order)
    return TrialTable(header, rows, "%s (%s)" % (spec.name, spec.program))


class Progress(object):
    """A progress bar on a stream (stderr): redrawn in place on a terminal, at most every
    10% as plain lines otherwise. `stream=None` disables it."""

    def __init__(self, total, label, stream=sys.stderr, width=30):
        self.total, self.label, self.stream, self.width = max(1, total), label, stream, width
        self.done, self.t0, self.last_decile = 0, time.monotonic(), -1
        self.tty = bool(stream) and hasattr(stream, "isatty") and stream.isatty()
        self.lock = threading.Lock()
        self._draw()

    def update(self, n):
        with self.lock:
            self.done += n
            self._draw()

    def _draw(self, final=False):
        if not self.stream:
            return
        frac = min(1.0, self.done / float(self.total))
        el = time.monotonic() - self.t0
        eta = el / frac - el if frac > 0 else float("nan")
        fill = int(round(frac * self.width))
        line = "[%s] %s%s %3d%% %d/%d trials %.1f s%s" % (
            self.label, "#" * fill, "." * (self.width - fill), int(frac * 100), self.done,
            self.total, el, "" if final or math.isnan(eta) else " eta %.0f s" % eta)
        if self.tty:
            self.stream.write("\r" + line + ("\n" if final else ""))
        else:
            decile = int(frac * 10)
            if decile == self.last_decile and not final:
                return
            self.last_decile = decile
            self.stream.write(line + "\n")
        self.stream.flush()

    def finish(self):
        with self.lock:
            if self.tty:
                self._draw(final=True)


def sha256_text(text):
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class Runner(object):
    """Runs TrialSpecs locally (`workers` CLI processes at a time) or on a Dask cluster.

    record_dir: where trials/<name>.csv are written (None: not saved).
    replay_dir: read trials/<name>.csv from there instead of running (its params.json, if any,
    must record the same program, options, seed and trials for each set).
    chunks_per_worker: chunks per worker slot over a run() call (more: finer progress and load
    balance, but each chunk pays the CLI's start-up cost).
    """

    def __init__(self, workers=None, scheduler=None, record_dir=None, replay_dir=None,
                 chunks_per_worker=4, progress=sys.stderr, timeout=None):
        if workers is not None and workers < 1:
            raise ValueError("workers must be at least 1, got %r" % (workers,))
        self.workers = workers or os.cpu_count() or 1
        self.scheduler, self.record_dir, self.replay_dir = scheduler, record_dir, replay_dir
        self.chunks_per_worker, self.progress, self.timeout = chunks_per_worker, progress, timeout
        self.records = collections.OrderedDict()
        self._cache = {}
        self._pending = collections.OrderedDict()  # name -> (spec, [(job, future)])
        self._pool = None
        self._client = None
        self._connect_timeout = "20s"
        self._replayed = None
        if replay_dir is not None:
            if not os.path.isdir(os.path.join(replay_dir, "trials")):
                raise FileNotFoundError("replay: %s has no trials/ folder (not an evaluation "
                                        "output folder?)" % replay_dir)
            pj = os.path.join(replay_dir, "params.json")
            if os.path.exists(pj):
                with open(pj) as f:
                    self._replayed = json.load(f).get("trial_sets", {})

    # ---- public
    def prefetch(self, specs):
        """Start trial sets in the background on the local pool, in this order, each split as
        run() would split it (a no-op when replaying or on a Dask cluster). A later run() of a
        prefetched set waits for its chunks instead of starting them, so the workers go on
        with the next experiment's chunks while one experiment finishes: no idle tails between
        experiments. Tables are the same as without (trial i depends only on (seed, i))."""
        if self.replay_dir is not None or self.scheduler:
            return
        todo = [s for s in specs if s.name not in self._cache and s.name not in self._pending]
        if not todo:
            return
        if self._pool is None:
            self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=self.workers)
        jobs, _ = self._plan(todo)
        threads = self._threads(jobs)
        for s in todo:
            self._pending[s.name] = (s, [])
        for j in jobs:
            f = self._pool.submit(chunk_mod.run_chunk, *self._args(j, threads))
            self._pending[j[0].name][1].append((j, f))

    def run(self, specs, label="trials"):
        """Run (or replay, or reuse from this runner's cache) the specs; {name: TrialTable}."""
        out, todo, waiting = collections.OrderedDict(), [], []
        for s in specs:
            if s.name in self._pending:
                spec = self._pending[s.name][0]
                if spec.key() != s.key():
                    raise ValueError("trial set %s requested with different settings in one run"
                                     % s.name)
                waiting.append(s.name)
            elif s.name in self._cache:
                key, table = self._cache[s.name]
                if key != s.key():
                    raise ValueError("trial set %s requested with different settings in one run"
                                     % s.name)
                out[s.name] = table
            elif s.name in (t.name for t in todo):
                raise ValueError("trial set name %s used twice" % s.name)
            else:
                todo.append(s)
        if waiting:
            self._collect(waiting, label)
        if todo:
            if self.replay_dir is not None:
                tables = {s.name: self._replay(s) for s in todo}
            else:
                tables = self._execute(todo, label)
            for s in todo:
                self._save(s, tables[s.name])
        for s in specs:
            out[s.name] = self._cache[s.name][1]
        return out

    def run_once(self, name, program, args, out_flag="--out"):
        """Run a program that is not trial-based (e.g. dialog_script) once, locally, and
        record / replay its CSV output like a trial set (first column need not be a trial)."""
        key = {"program": program, "args": [str(a) for a in args], "out_flag": out_flag}
        if name in self._cache:
            if self._cache[name][0] != key:
                raise ValueError("output %s requested with different settings in one run" % name)
            return self._cache[name][1]
        if self.replay_dir is not None:
            p = os.path.join(self.replay_dir, "trials", name + ".csv")
            if not os.path.exists(p):
                raise FileNotFoundError("replay: %s is missing" % p)
            rec = (self._replayed or {}).get(name, {})
            for k, v in key.items():
                if k in rec and rec[k] != v:
                    raise ValueError("replay: %s was recorded with %s = %r, this run asks for %r"
                                     % (p, k, rec[k], v))
            table = TrialTable.read(p)
        else:
            text = chunk_mod.run_program(program, paths.program(program), args, out_flag,
                                         root=paths.root(), timeout=self.timeout)[0]
            table = TrialTable.from_text(text, "%s (%s)" % (name, program))
        self._store(name, key, table)
        return table

    def close(self):
        if self._pool is not None:
            for _, jobs in self._pending.values():
                for _, f in jobs:
                    f.cancel()
            self._pool.shutdown(wait=True)
            self._pool = None
            self._pending.clear()
        if self._client is not None:
            self._client.close()
            self._client = None

    def slots(self):
        """Number of trial chunks that can run at the same time."""
        if self.scheduler:
            return max(1, sum(self._dask().nthreads().values()))
        return self.workers

    # ---- internals
    def _save(self, spec, table):
        self._store(spec.name, spec.key(), table)

    def _store(self, name, key, table):
        text = table.to_text()
        rec = dict(key, rows=len(table), sha256=sha256_text(text),
                   file=os.path.join("trials", name + ".csv"))
        if self.record_dir is not None:
            d = os.path.join(self.record_dir, "trials")
            os.makedirs(d, exist_ok=True)
            p = os.path.join(d, name + ".csv")
            if not (self.replay_dir and os.path.samefile(self.replay_dir, self.record_dir)):
                tmp = p + ".tmp"
                with open(tmp, "w", newline="") as f:
                    f.write(text)
                os.replace(tmp, p)
        self.records[name] = rec
        self._cache[name] = (key, table)

    def _replay(self, spec):
        p = os.path.join(self.replay_dir, "trials", spec.name + ".csv")
        if not os.path.exists(p):
            raise FileNotFoundError("replay: %s is missing (that experiment was not run with "
                                    "these settings in %s)" % (p, self.replay_dir))
        if self._replayed is not None and spec.name in self._replayed:
            rec = self._replayed[spec.name]
            for k, v in spec.key().items():
                if k in rec and rec[k] != v:
                    raise ValueError("replay: %s was recorded with %s = %r, this run asks for %r "
                                     "(use the recorded parameters or rerun)"
                                     % (p, k, rec[k], v))
        t = TrialTable.read(p)
        idx = t.trial_indices()
        if set(idx) != set(range(spec.trials)):
            raise ValueError("replay: %s holds trial indices %d..%d (%d distinct), expected "
                             "0..%d" % (p, min(idx) if idx else -1, max(idx) if idx else -1,
                                        len(set(idx)), spec.trials - 1))
        return t

    def _plan(self, specs):
        total = sum(s.trials for s in specs)
        work = sum(s.trials * s.cost for s in specs)
        target = max(1, self.slots() * self.chunks_per_worker)
        jobs = []
        for s in specs:
            # Ceiled: one chunk per set (rounding six sets on 2 slots) saved 3 % of exp2's CPU
            # but lost 6 s of wall time to imbalance (the first chunk of a set learns/solves).
            n = int(math.ceil(target * s.trials * s.cost / work))
            n = max(1, min(n, s.trials // s.min_chunk))
            path = paths.program(s.program)
            for k, (begin, count) in enumerate(split(s.trials, n)):
                jobs.append((k, s, path, begin, count))
        # Longest (in CPU) first balances the pool; among equal ones, the first chunk of every
        # set before any second one, so the workers start on different sets (a set's first
        # chunk may learn or solve what its other chunks then load from the cache).
        jobs.sort(key=lambda j: (-j[4] * j[1].cost, j[0]))
        return [j[1:] for j in jobs], total

    def _execute(self, specs, label):
        jobs, total = self._plan(specs)
        bar = Progress(total, label, self.progress)
        parts = collections.defaultdict(list)
        try:
            if self.scheduler:
                self._execute_dask(jobs, parts, bar)
            else:
                self._execute_local(jobs, parts, bar)
        finally:
            bar.finish()
        return {s.name: assemble(s, parts[s.name]) for s in specs}

    def _args(self, job, threads=1):
        s, path, begin, count = job
        return (s.program, path, s.args, s.seed, begin, count, s.trials_flag, s.scratch_flags,
                threads, self.timeout, paths.root())

    def _threads(self, jobs):
        """Threads per CLI process: 1, unless there are fewer chunks than slots (e.g. one
        chunk of a CLI whose start-up is too costly to split): then the idle slots go to
        them. Trial i depends only on (seed, i), so threads never change a table."""
        return max(1, self.slots() // len(jobs)) if jobs else 1

    def _collect(self, names, label):
        """Wait for prefetched sets, assemble and save them (a failed chunk raises here)."""
        entries = [self._pending.pop(n) for n in names]
        bar = Progress(sum(s.trials for s, _ in entries), label, self.progress)
        try:
            futs = {f: j for _, jobs in entries for j, f in jobs}
            parts = collections.defaultdict(list)
            for f in concurrent.futures.as_completed(futs):
                s, _, begin, count = futs[f]
                parts[s.name].append((begin, count, f.result()[0]))
                bar.update(count)
        except BaseException:
            for f in futs:
                f.cancel()
            raise
        finally:
            bar.finish()
        for s, _ in entries:
            self._save(s, assemble(s, parts[s.name]))

    def _execute_local(self, jobs, parts, bar):
        threads = self._threads(jobs)
        with concurrent.futures.ThreadPoolExecutor(max_workers=self.workers) as pool:
            futs = {pool.submit(chunk_mod.run_chunk, *self._args(j, threads)): j for j in jobs}
            try:
                for f in concurrent.futures.as_completed(futs):
                    s, _, begin, count = futs[f]
                    text = f.result()[0]
                    parts[s.name].append((begin, count, text))
                    bar.update(count)
            except BaseException:
                for f in futs:
                    f.cancel()
                raise

    def _dask(self):
        if self._client is None:
            import cloudpickle
            from distributed import Client
            # Ship the chunk runner by value: workers need the CLIs, not this package.
            cloudpickle.register_pickle_by_value(chunk_mod)
            try:
                self._client = Client(self.scheduler, timeout=self._connect_timeout)
            except (OSError, TimeoutError) as e:
                raise ConnectionError("cannot reach the Dask scheduler at %s: %s"
                                      % (self.scheduler, e))
        return self._client

    def _execute_dask(self, jobs, parts, bar):
        from distributed import as_completed
        client = self._dask()
        futs = {}
        for j in jobs:
            f = client.submit(chunk_mod.run_chunk, *self._args(j), pure=False)
            futs[f] = j
        try:
            for f in as_completed(list(futs)):
                s, _, begin, count = futs[f]
                text = f.result()[0]
                parts[s.name].append((begin, count, text))
                bar.update(count)
        except BaseException:
            client.cancel(list(futs))
            raise
