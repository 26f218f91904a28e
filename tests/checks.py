"""Pass/fail bookkeeping shared by the Python end-to-end tests: `check` records one assertion
(printing the message of a failed one), `finish` prints the counts and exits with status 1
when any check failed. `load_script` imports one of scripts/ (files without a .py suffix) as a
module, so that a test can call its functions."""
import importlib.machinery
import importlib.util
import sys

failures = []
passed = 0


def check(condition, message):
    global passed
    if condition:
        passed += 1
    else:
        failures.append(message)
        print("FAIL:", message)


def finish():
    print(f"{passed} passed, {len(failures)} failed")
    sys.exit(1 if failures else 0)


def load_script(path, name):
    """The script at `path` as a module called `name` (its main() is not run)."""
    loader = importlib.machinery.SourceFileLoader(name, path)
    spec = importlib.util.spec_from_loader(name, loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module
