"""Pass/fail bookkeeping shared by the Python end-to-end tests: `check` records one assertion
(printing the message of a failed one), `finish` prints the counts and exits with status 1
when any check failed."""
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
