"""Where the Python tests find the Stanford models: as the renderer does, in the folders of
CBDPT_MODEL_PATH (the C++ twin is tests/stanford_models.h). Not a script of its own."""
import os

NAMES = ("bunny.ply", "dragon.ply", "buddha.ply")
HOW = ("the Stanford models (bunny.ply, dragon.ply, buddha.ply) are not in any folder of "
       "CBDPT_MODEL_PATH (\"{}\"); run scripts/get-models and set CBDPT_MODEL_PATH=$PWD/models")


def model_dir():
    """The first folder of CBDPT_MODEL_PATH holding all three models, or None."""
    for d in os.environ.get("CBDPT_MODEL_PATH", "").split(os.pathsep):
        if d and all(os.path.isfile(os.path.join(d, n)) for n in NAMES):
            return d
    return None


def required():
    """CI sets CBDPT_REQUIRE_MODELS=1: there a missing model is a failure, not a skip."""
    return os.environ.get("CBDPT_REQUIRE_MODELS") == "1"


def missing_message():
    return HOW.format(os.environ.get("CBDPT_MODEL_PATH", ""))


def skip_without_models():
    """Exit the test unless the models are found: as skipped ("cbdpt-skip:", the
    SKIP_REGULAR_EXPRESSION of tests/tests.cmake), or as failed where they are required."""
    if model_dir() is not None:
        return
    if required():
        print("FAIL: CBDPT_REQUIRE_MODELS=1 but " + missing_message())
        raise SystemExit(1)
    print("cbdpt-skip: " + missing_message())
    raise SystemExit(0)
