#!/usr/bin/env python3
"""Docs describe the present: every file or folder of this repository that the README or a page
of docs/ names in backticks (`src/...`, `kernels/...`, `scripts/...`, `tests/...`, `docs/...`,
`scenes/...`) exists, or is the start of a name that does (`kernels/cb_` for the shared
headers). The few names that are not ours are listed below with the reason. A self-check feeds
the scanner a page naming a missing file and a glob, so that it cannot pass by finding nothing.

Usage: test_docs_paths.py REPO_ROOT"""
import glob
import os
import re
import sys

root = os.path.abspath(sys.argv[1])
sys.path.insert(0, os.path.join(root, "tests"))
from checks import check, finish  # noqa: E402

# Named on purpose although not in this repository.
NOT_OURS = {
    "src/ext/": "pbrt-v4's submodule folder (docs/pbrt-v4.md)",
    "src/pbrt/util/pmj02tables.cpp": "a file of pbrt-v4 (docs/pbrt-v4.md)",
    "scripts/gpu-bisect": "named as history: in git before 5cf0dd6 (docs/gpu.md)",
}
NAME = re.compile(r"`((?:src|kernels|scripts|tests|docs|scenes)/[A-Za-z0-9_./*-]*)")


def missing_names(text):
    """(line, name) for each repository path named in `text` that nothing in the tree matches."""
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        for match in NAME.finditer(line):
            name = match.group(1).rstrip(".,:;")
            if name in NOT_OURS:
                continue
            pattern = os.path.join(root, name)
            if "*" in name:
                exists = bool(glob.glob(pattern))
            else:
                exists = os.path.exists(pattern) or bool(glob.glob(glob.escape(pattern) + "*"))
            if not exists:
                found.append((number, name))
    return found


pages = [os.path.join(root, "README.md")] + sorted(glob.glob(os.path.join(root, "docs", "*.md")))
check(len(pages) > 10, f"the README and the docs pages are found ({len(pages)})")
named = 0
all_text = ""
for page in pages:
    with open(page, encoding="utf-8") as f:
        text = f.read()
    all_text += text
    named += len(NAME.findall(text))
    for number, name in missing_names(text):
        check(False, f"{os.path.relpath(page, root)}:{number}: `{name}` is not in the repository")
check(named > 200, f"the pages name many repository paths ({named})")
for name, why in NOT_OURS.items():
    check(f"`{name}" in all_text, f"`{name}` ({why}) is still named somewhere, or leaves NOT_OURS")

# The scanner itself: a missing file and a glob matching nothing are found; a prefix is not.
sample = "see `src/io/files.cpp`, `src/io/gone.cpp`,\n`kernels/cb_` and `tests/*.nothing`."
check(missing_names(sample) == [(1, "src/io/gone.cpp"), (2, "tests/*.nothing")],
      f"the scanner finds a missing file and an empty glob ({missing_names(sample)})")
finish()
