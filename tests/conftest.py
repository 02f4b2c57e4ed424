import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

# Keep every test's speech cache inside the test session, never in the user's home.
os.environ.setdefault("SGT_CACHE_DIR", str(ROOT / ".pytest_cache" / "sgt-speech"))

GESTURES = ["open_arms", "point_right", "point_left", "wave", "nod", "beat_both", "count_one", "count_two"]


@pytest.fixture
def names():
    return list(GESTURES)


@pytest.fixture
def shared_dir():
    """A temporary folder another user (nobody, for permission tests run as root) can reach."""
    from special_files import shared_folder

    with shared_folder() as d:
        yield d
