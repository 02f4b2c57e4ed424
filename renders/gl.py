"""Choosing and starting an offscreen OpenGL platform for pyrender (lazily).

``PYOPENGL_PLATFORM`` must be set before anything imports :mod:`OpenGL`, and the choice
cannot be changed afterwards inside one process without purging the modules. Order:

1. ``SGT_GL`` or ``PYOPENGL_PLATFORM`` when the user set one (``egl`` or ``osmesa``);
2. otherwise EGL (Mesa's software device works without a GPU), then OSMesa.

Workarounds applied here, all measured on the project's machines:

* pyrender 0.1.45 uses ``np.infty``, which numpy 2 removed;
* PyOpenGL 3.1.0 (the version pyrender 0.1.45 pins) lacks ``OSMesaCreateContextAttribs``,
  which pyrender's OSMesa platform imports: it is declared here from ``libOSMesa``;
* trimesh (imported by pyrender) swallows a ctrl+c that lands during its imports
  (``except BaseException``): SIGINT is held while the GL stack is imported and delivered
  after (:mod:`core.interrupts`);
* under OSMesa, ``OpenGL.contextdata.getContext`` returns a fresh ctypes pointer for the
  same context on every call, so per-context caches never hit and memory grows every
  frame: it is made to return the context's address (a stable int).
"""

from __future__ import annotations

import os
import sys

from core.interrupts import interrupts_deferred

PLATFORMS = ("egl", "osmesa")
INSTALL_HINT = (
    "offscreen rendering needs EGL or OSMesa: on Debian/Ubuntu install them with\n"
    "  apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6\n"
    "and the Python packages with  pip install 'pyrender==0.1.45' trimesh pillow"
)


class RenderSetupError(Exception):
    """No offscreen OpenGL platform could be started."""


_state: dict = {}


def _purge_gl_modules() -> None:
    for name in list(sys.modules):
        if name == "OpenGL" or name.startswith(("OpenGL.", "pyrender")):
            del sys.modules[name]


def _patch_numpy() -> None:
    import numpy as np

    if not hasattr(np, "infty"):
        np.infty = np.inf


def _patch_osmesa() -> None:
    import ctypes

    import OpenGL.osmesa as osm
    from OpenGL import contextdata
    from OpenGL import platform as glplatform

    if not hasattr(osm, "OSMesaCreateContextAttribs"):
        from OpenGL.raw.osmesa._types import OSMesaContext

        lib = glplatform.PLATFORM.OSMesa
        fn = lib.OSMesaCreateContextAttribs
        fn.restype = OSMesaContext
        fn.argtypes = [ctypes.POINTER(ctypes.c_int), OSMesaContext]
        constants = {  # from Mesa's GL/osmesa.h
            "OSMESA_DEPTH_BITS": 0x30,
            "OSMESA_STENCIL_BITS": 0x31,
            "OSMESA_ACCUM_BITS": 0x32,
            "OSMESA_PROFILE": 0x33,
            "OSMESA_CORE_PROFILE": 0x34,
            "OSMESA_COMPAT_PROFILE": 0x35,
            "OSMESA_CONTEXT_MAJOR_VERSION": 0x36,
            "OSMESA_CONTEXT_MINOR_VERSION": 0x37,
        }

        def create_context_attribs(attribs, sharelist):
            arr = (ctypes.c_int * len(attribs))(*[int(a) for a in attribs])
            return fn(arr, sharelist)

        osm.OSMesaCreateContextAttribs = create_context_attribs
        for k, v in constants.items():
            if not hasattr(osm, k):
                setattr(osm, k, v)

    original = contextdata.getContext

    def stable_get_context(context=None):
        ctx = original(context)
        try:
            return ctypes.cast(ctx, ctypes.c_void_p).value or ctx
        except (TypeError, ctypes.ArgumentError):
            return ctx

    if not getattr(contextdata.getContext, "_sgt_stable", False):
        stable_get_context._sgt_stable = True
        contextdata.getContext = stable_get_context


def _try(platform: str, width: int, height: int):
    os.environ["PYOPENGL_PLATFORM"] = platform
    # pyrender imports trimesh, whose imports swallow KeyboardInterrupt (``except
    # BaseException``): a ctrl+c during them is held and delivered after.
    with interrupts_deferred():
        _patch_numpy()
        if platform == "osmesa":
            _patch_osmesa()
        import pyrender

        return pyrender, pyrender.OffscreenRenderer(width, height)


def start(width: int, height: int):
    """Return ``(pyrender, OffscreenRenderer, platform_name)``; raises RenderSetupError."""
    wanted = os.environ.get("SGT_GL") or None
    if "platform" in _state:
        order = [_state["platform"]]
    elif wanted or os.environ.get("PYOPENGL_PLATFORM"):
        order = [(wanted or os.environ["PYOPENGL_PLATFORM"]).lower()]
    else:
        order = list(PLATFORMS)
    errors = []
    for platform in order:
        if platform not in PLATFORMS:
            raise RenderSetupError(f"unknown GL platform '{platform}': use egl or osmesa")
        try:
            pyrender, renderer = _try(platform, width, height)
        except Exception as exc:  # the platform's libraries are missing or broken
            errors.append(f"{platform}: {type(exc).__name__}: {exc}")
            _purge_gl_modules()
            continue
        _state["platform"] = platform
        return pyrender, renderer, platform
    raise RenderSetupError("could not start offscreen OpenGL (" + "; ".join(errors) + ")\n" + INSTALL_HINT)
