"""Where the repository, its configuration and the built programs are."""
import os
import shutil

ROOT = os.environ.get("KRR_ROOT") or os.path.dirname(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def repo(*parts):
    """Absolute path of a file in the repository."""
    return os.path.join(ROOT, *parts)


def bin_dir():
    """$KRR_BIN_DIR if set (then the only place programs are looked up), else None."""
    return os.environ.get("KRR_BIN_DIR") or None


def program(name):
    """Path of a core program: $KRR_BIN_DIR/name if that variable is set (nothing else is
    searched then), else the catkin devel space, then PATH."""
    override = bin_dir()
    if override:
        p = os.path.join(override, name)
        if os.path.isfile(p) and os.access(p, os.X_OK):
            return p
        raise FileNotFoundError("%s: no executable %s in KRR_BIN_DIR=%s" % (name, p, override))
    p = repo("catkin_ws", "devel", "lib", "krr_core", name)
    if os.path.exists(p):
        return p
    found = shutil.which(name)
    if found:
        return found
    raise FileNotFoundError(
        "%s is not built: run tools/build.sh first (looked in %s and PATH)" % (name, p))
