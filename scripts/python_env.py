"""Runs the importing script under the project's Python environment: the virtual environment
.venv/ that scripts/install-deps makes from scripts/requirements.txt (pinned versions), or the
one named by $CBDPT_VENV. Import it before anything outside the standard library:

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python)

Without that environment the script goes on with the interpreter it was started with, and a
missing package is reported with the command that installs it (python_env.require)."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VENV = os.environ.get("CBDPT_VENV") or os.path.join(ROOT, ".venv")
INSTALL_HINT = "run scripts/install-deps (it makes .venv/ from scripts/requirements.txt)"


def _reexecute():
    python = os.path.join(VENV, "bin", "python")
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV) or not os.path.exists(python):
        return
    if os.environ.get("CBDPT_VENV_ACTIVE") == VENV:
        return  # already re-executed once: never loop
    if not sys.argv or not os.path.isfile(sys.argv[0]):
        return  # python -c or an interactive session: nothing to re-execute
    os.environ["CBDPT_VENV_ACTIVE"] = VENV
    os.execv(python, [python] + sys.argv)


def require(module, what):
    """Imports `module`, or exits with a message naming `what` needs it and how to install it."""
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError:
        raise SystemExit(f"{os.path.basename(sys.argv[0])}: {what} needs the Python package "
                         f"'{module}': {INSTALL_HINT}") from None


_reexecute()
