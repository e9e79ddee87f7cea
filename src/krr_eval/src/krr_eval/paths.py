"""Where the repository, its configuration and the built programs are.

The repository root (config/, maps/, docs/, catkin_ws/) is found independently of the current
directory, so that every CLI works from anywhere (`cd /tmp && rosrun krr_eval evaluate`):
  1. $KRR_ROOT if set;
  2. else two levels above this package's directory (src/krr_eval -> the repository), from
     this file's real path (through the catkin_ws/src symlink and the devel space's
     catkin_python_setup redirect);
  3. else two levels above the package path ROS knows (rospkg, i.e. `rospack find krr_eval`).
"""
import os
import shutil

MARKER = ("config", "dialog.yaml")  # a file every checkout has at its root


def _is_root(d):
    return bool(d) and os.path.isfile(os.path.join(d, *MARKER))


def find_root():
    """The repository root (see the module's docstring); raises RuntimeError if none is."""
    env = os.environ.get("KRR_ROOT")
    if env:
        return os.path.realpath(env)
    here = os.path.dirname(os.path.realpath(__file__))  # <root>/src/krr_eval/src/krr_eval
    candidate = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(here))))
    if _is_root(candidate):
        return candidate
    try:
        import rospkg
        pkg = os.path.realpath(rospkg.RosPack().get_path("krr_eval"))
        candidate = os.path.dirname(os.path.dirname(pkg))
        if _is_root(candidate):
            return candidate
    except Exception:  # rospkg missing, or the package not on ROS_PACKAGE_PATH
        pass
    raise RuntimeError("krr_eval: cannot find the repository root (config/dialog.yaml): set "
                       "KRR_ROOT, or source catkin_ws/devel/setup.bash")


try:
    ROOT = find_root()
except RuntimeError:  # reported when a path is asked for
    ROOT = None


def root():
    if ROOT is None:
        return find_root()  # raises with the explanation
    return ROOT


def repo(*parts):
    """Absolute path of a file in the repository."""
    return os.path.join(root(), *parts)


def bin_dir():
    """$KRR_BIN_DIR if set (then the only place programs are looked up), else None."""
    return os.environ.get("KRR_BIN_DIR") or None


def program(name):
    """Path of a core program: $KRR_BIN_DIR/name if that variable is set (nothing else is
    searched then), else the repository's catkin devel space, then lib/krr_core of every
    $CMAKE_PREFIX_PATH entry (a sourced devel or install space), then PATH."""
    override = bin_dir()
    if override:
        p = os.path.join(override, name)
        if os.path.isfile(p) and os.access(p, os.X_OK):
            return p
        raise FileNotFoundError("%s: no executable %s in KRR_BIN_DIR=%s" % (name, p, override))
    p = repo("catkin_ws", "devel", "lib", "krr_core", name)
    if os.path.exists(p):
        return p
    for prefix in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep):
        q = os.path.join(prefix, "lib", "krr_core", name) if prefix else ""
        if q and os.path.isfile(q) and os.access(q, os.X_OK):
            return q
    found = shutil.which(name)
    if found:
        return found
    raise FileNotFoundError(
        "%s is not built: run tools/build.sh first (looked in %s, $CMAKE_PREFIX_PATH and PATH)"
        % (name, p))
