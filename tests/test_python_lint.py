#!/usr/bin/env python3
"""Warnings on, no warnings, for the Python code too: pyflakes finds nothing in scripts/ (its
Python files, with or without the .py suffix) and tests/*.py. The one message taken as intended
is `'python_env' imported but unused`: that import re-executes the script under .venv/
(scripts/python_env.py), its effect is the import itself. A self-check lints a file with an
unused import and an undefined name, so that the test cannot pass by linting nothing.

Usage: test_python_lint.py REPO_ROOT"""
import glob
import os
import sys

root = os.path.abspath(sys.argv[1])
sys.path.insert(0, os.path.join(root, "scripts"))
import python_env  # noqa: F401,E402  (re-executes under .venv/bin/python)

sys.path.insert(0, os.path.join(root, "tests"))
from checks import check, finish  # noqa: E402

pyflakes_api = python_env.require("pyflakes.api", "the Python lint test")
pyflakes_reporter = python_env.require("pyflakes.reporter", "the Python lint test")

INTENDED = "'python_env' imported but unused"


class Collect(pyflakes_reporter.Reporter):
    def __init__(self):
        self.messages = []

    def unexpectedError(self, filename, message):
        self.messages.append(f"{filename}: {message}")

    def syntaxError(self, filename, message, lineno, offset, text):
        self.messages.append(f"{filename}:{lineno}: syntax error: {message}")

    def flake(self, message):
        text = str(message)
        if INTENDED not in text:
            self.messages.append(text)


def lint(path, source=None):
    """pyflakes' messages on `path` (or on `source`, named `path`), the intended one left out."""
    reporter = Collect()
    if source is None:
        with open(path, encoding="utf-8") as f:
            source = f.read()
    pyflakes_api.check(source, path, reporter)
    return reporter.messages


def python_files():
    files = sorted(glob.glob(os.path.join(root, "tests", "*.py")))
    for path in sorted(glob.glob(os.path.join(root, "scripts", "*"))):
        if not os.path.isfile(path):
            continue
        if path.endswith(".py"):
            files.append(path)
            continue
        with open(path, encoding="utf-8", errors="replace") as f:
            first = f.readline()
        if first.startswith("#!") and "python" in first:
            files.append(path)
    return files


# The self-check: both defects are reported, and the intended message is not.
sample = "import os\nimport python_env\nprint(undefined_name)\n"
found = lint("sample.py", sample)
check(any("'os' imported but unused" in m for m in found), f"self-check: unused import ({found})")
check(any("undefined name 'undefined_name'" in m for m in found),
      f"self-check: undefined name ({found})")
check(not any("python_env" in m for m in found), f"self-check: python_env left out ({found})")

files = python_files()
check(len(files) >= 30, f"found {len(files)} Python files in scripts/ and tests/ (expected 30+)")
check(any(f.endswith("scripts/report") for f in files), "scripts/report (no suffix) is linted")
for path in files:
    messages = lint(path)
    check(not messages, f"{os.path.relpath(path, root)}:\n  " + "\n  ".join(messages))
finish()
