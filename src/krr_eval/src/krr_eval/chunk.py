"""Run one chunk of trials of a core CLI and return its per-trial CSV text.

This module uses the standard library only and has no package-relative imports, so the
runner can ship it by value to Dask workers that do not have krr_eval on their path.

CLI contract: `PROGRAM [experiment options] --seed S --trials N --trial-begin K --threads T
<trials flag> FILE.csv` writes one CSV row (or several, e.g. one per episode) per trial, trial
index in the first column, trial i depending only on (seed, i).
"""
import os
import shlex
import shutil
import signal
import subprocess
import tempfile
import time


class ChunkError(RuntimeError):
    """A CLI run of one chunk failed; the message names the command and its error output."""


def resolve_program(name, fallback_path):
    """The program to run on this machine: $KRR_BIN_DIR/name if that variable is set here,
    else the path the client resolved."""
    bin_dir = os.environ.get("KRR_BIN_DIR")
    if bin_dir:
        p = os.path.join(bin_dir, name)
        if os.path.exists(p):
            return p
    return fallback_path


def resolve_root(fallback_root):
    """Working directory for the CLIs (relative config paths): $KRR_ROOT here, else the
    client's repository root."""
    return os.environ.get("KRR_ROOT") or fallback_root


def run_program(program, path, args, out_flag, root=None, timeout=None, what=""):
    """Run `program args out_flag FILE` once in the repository root; returns (text, seconds,
    command line). Raises ChunkError naming the command and its stderr on failure."""
    exe = resolve_program(program, path)
    cwd = resolve_root(root) if root else None
    tmp = tempfile.mkdtemp(prefix="krr_chunk_")
    try:
        out = os.path.join(tmp, "out.csv")
        cmd = [exe] + [str(a) for a in args] + [out_flag, out]
        return _run(program, cmd, out, out_flag, cwd, timeout, what)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _run(program, cmd, out, out_flag, cwd, timeout, what):
    t0 = time.monotonic()
    try:
        res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=cwd,
                             timeout=timeout, universal_newlines=True)
    except OSError as e:
        raise ChunkError("cannot run %s: %s" % (cmd[0], e))
    except subprocess.TimeoutExpired:
        raise ChunkError("%s timed out after %s s%s: %s"
                         % (program, timeout, what, shlex.join(cmd)))
    seconds = time.monotonic() - t0
    if res.returncode != 0:
        tail = "\n".join(res.stderr.strip().splitlines()[-15:])
        if res.returncode < 0:
            try:
                how = "was killed by signal %s" % signal.Signals(-res.returncode).name
            except ValueError:
                how = "was killed by signal %d" % -res.returncode
        else:
            how = "failed with exit code %d" % res.returncode
        raise ChunkError("%s %s%s\n  command: %s\n  %s"
                         % (program, how, what, shlex.join(cmd), tail.replace("\n", "\n  ")))
    if not os.path.exists(out):
        raise ChunkError("%s exited 0 but wrote no file for %s\n  command: %s"
                         % (program, out_flag, shlex.join(cmd)))
    with open(out, newline="") as f:
        return f.read(), seconds, shlex.join(cmd)


def run_chunk(program, path, args, seed, begin, count, trials_flag="--out",
              scratch_flags=(), threads=1, timeout=None, root=None):
    """Run trials [begin, begin + count) and return (csv_text, seconds, command line).

    program: the CLI's name; path: where the client found it (a worker's own $KRR_BIN_DIR
    wins); args: experiment options; trials_flag: the option taking the per-trial CSV path;
    scratch_flags: options that also take an output path whose content is not needed.
    Raises ChunkError with the command, return code and the tail of stderr on failure.
    """
    exe = resolve_program(program, path)
    cwd = resolve_root(root) if root else None
    tmp = tempfile.mkdtemp(prefix="krr_chunk_")
    try:
        out = os.path.join(tmp, "trials.csv")
        cmd = [exe] + [str(a) for a in args] + [
            "--seed", str(seed), "--trials", str(count), "--trial-begin", str(begin),
            "--threads", str(threads), trials_flag, out]
        for i, flag in enumerate(scratch_flags):
            cmd += [flag, os.path.join(tmp, "scratch%d.csv" % i)]
        return _run(program, cmd, out, trials_flag, cwd, timeout,
                    " on trials %d..%d" % (begin, begin + count - 1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
