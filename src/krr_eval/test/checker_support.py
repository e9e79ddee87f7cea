"""Running one of the repository's source checkers (test/check_*.py) on the repository or on a
temporary tree: shared by the checkers' test suites."""
import os
import subprocess
import sys
import tempfile

from krr_eval import paths


def script(name):
    """test/<name> of the repository."""
    return os.path.join(paths.root(), "test", name)


def run(checker, root=None):
    """The checker (a script path) on `root` (default: the repository)."""
    cmd = [sys.executable, checker] + (["--root", root] if root else [])
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def run_on_tree(checker, files):
    """The checker on a temporary tree holding `files` ({relative path: text})."""
    with tempfile.TemporaryDirectory() as root:
        for rel, text in files.items():
            os.makedirs(os.path.dirname(os.path.join(root, rel)), exist_ok=True)
            with open(os.path.join(root, rel), "w") as f:
                f.write(text)
        return run(checker, root)
