"""``sgt build``: incremental, deterministic, parallel builds of many scripts (see :mod:`.builder`)."""

from sgt_tui.build.builder import Progress, Report, build, find_sources
from sgt_tui.build.cache import BuildCache
from sgt_tui.build.keys import Settings

__all__ = ["BuildCache", "Progress", "Report", "Settings", "build", "find_sources"]
