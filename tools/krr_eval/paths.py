"""Where the repository, its configuration and the built programs are."""
import os
import shutil

ROOT = os.environ.get("KRR_ROOT") or os.path.dirname(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def repo(*parts):
    """Absolute path of a file in the repository."""
    return os.path.join(ROOT, *parts)


def program(name):
    """Path of a core program (catkin devel space first, then PATH)."""
    p = repo("catkin_ws", "devel", "lib", "krr_core", name)
    if os.path.exists(p):
        return p
    found = shutil.which(name)
    if found:
        return found
    raise FileNotFoundError(
        "%s is not built: run tools/build.sh first (looked in %s and PATH)" % (name, p))
