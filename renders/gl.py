"""Choosing and starting an offscreen OpenGL platform (lazily), and drawing one shaded mesh in it.

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

Drawing (:class:`MeshRenderer`): pyrender's scene renderer costs about 1 ms of Python per
node and frame (uniforms looked up and set per node and light), 50 nodes for the mannequin:
most of a frame. Here the whole mannequin is one triangle mesh, posed on the CPU (numpy), drawn
with one call and pyrender's own metallic-roughness shading (the same formulas, directional
lights, ambient, gamma), into a 4x multisampled framebuffer read back as RGB. pyrender is kept
for what it does once: creating the EGL or OSMesa context.
"""

from __future__ import annotations

import ctypes
import os
import sys
from dataclasses import dataclass

import numpy as np

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


# -- drawing -------------------------------------------------------------------------------

_VERTEX_SHADER = """#version 330 core
#define N_PARTS {n_parts}
layout(location = 0) in vec3 position;  // in its part's frame
layout(location = 1) in vec3 normal;
layout(location = 2) in vec4 material;  // linear base colour, roughness
layout(location = 3) in float part;
uniform mat4 VP;
uniform vec4 parts[3 * N_PARTS];  // each part's 3x4 transform, row by row
out vec3 frag_position;
out vec3 frag_normal;
out vec4 frag_material;
void main() {{
    int k = 3 * int(part + 0.5);
    mat4x3 m = transpose(mat3x4(parts[k], parts[k + 1], parts[k + 2]));
    mat3 r = mat3(m);
    frag_position = m * vec4(position, 1.0);
    // A part's transform is a rotation times a scale along its own axes (the palms): the
    // normal matrix transpose(inverse(r)) is then r scaled by the inverse squared axis lengths.
    frag_normal = normalize(r * (normal / vec3(dot(r[0], r[0]), dot(r[1], r[1]), dot(r[2], r[2]))));
    frag_material = material;
    gl_Position = VP * vec4(frag_position, 1.0);
}}
"""

#: pyrender 0.1.45's mesh.frag for a metallic-roughness material with metallic 0, no textures,
#: directional lights only: the same PBR terms, so the mannequin looks as it did (pixels within
#: 1 of pyrender's), with the light count fixed when the shader is built.
_FRAGMENT_SHADER = """#version 330 core
#define N_LIGHTS {n_lights}
in vec3 frag_position;
in vec3 frag_normal;
in vec4 frag_material;
out vec4 frag_color;
uniform vec3 cam_pos;
uniform vec3 ambient_light;
uniform vec3 light_direction[N_LIGHTS];
uniform vec3 light_radiance[N_LIGHTS];
const float PI = 3.141592653589793;
const float min_roughness = 0.04;
void main() {{
    float roughness = clamp(frag_material.a, min_roughness, 1.0);
    vec3 base = frag_material.rgb;
    vec3 c_diff = base * (1.0 - min_roughness);
    vec3 f0 = vec3(min_roughness);
    vec3 n = normalize(frag_normal);
    vec3 v = normalize(cam_pos - frag_position);
    vec3 color = vec3(0.0);
    float r = roughness + 1.0;
    float k = r * r / 8.0;
    float a2 = roughness * roughness * roughness * roughness;
    float nv = clamp(abs(dot(n, v)), 0.001, 1.0);
    float gv = nv / (nv * (1.0 - k) + k);
    for (int i = 0; i < N_LIGHTS; i++) {{
        vec3 l = -light_direction[i];
        vec3 h = normalize(l + v);
        float nl = clamp(dot(n, l), 0.001, 1.0);
        float nh = clamp(dot(n, h), 0.0, 1.0);
        float vh = clamp(dot(v, h), 0.0, 1.0);
        float fresnel = 1.0 - vh;
        float f2 = fresnel * fresnel;
        vec3 F = f0 + (1.0 - f0) * (f2 * f2 * fresnel);
        float G = gv * (nl / (nl * (1.0 - k) + k));
        float denom = nh * nh * (a2 - 1.0) + 1.0;
        float D = a2 / (PI * denom * denom);
        vec3 diffuse = (1.0 - F) * c_diff / PI;
        vec3 specular = F * G * D / (4.0 * nl * nv + 0.001);
        color += nl * light_radiance[i] * (diffuse + specular);
    }}
    color += base * ambient_light;
    frag_color = clamp(vec4(pow(color, vec3(1.0 / 2.2)), 1.0), 0.0, 1.0);
}}
"""

#: Samples per pixel of the multisampled framebuffer (pyrender's, too).
SAMPLES = 4


@dataclass
class Frame:
    """One draw of a :class:`MeshRenderer`: each part's transform ``parts`` (P, 4, 4) (part to
    world), ``materials`` (V, 4: linear RGB and roughness per vertex), the camera
    (``view_projection`` (4, 4) and its position ``eye``), directional ``lights`` ((direction
    the light shines along, linear RGB radiance), ...), the ``ambient`` light and the
    ``background`` (RGB 0..255)."""

    parts: np.ndarray
    materials: np.ndarray
    view_projection: np.ndarray
    eye: np.ndarray
    lights: list
    ambient: tuple
    background: tuple


class MeshRenderer:
    """A triangle mesh made of rigid parts, drawn offscreen.

    The mesh is fixed: ``vertices`` and ``normals`` (V, 3) in their part's frame, ``part`` (V,)
    the part of each vertex, ``indices`` (F, 3). Each frame moves the parts (one small uniform
    upload; the GPU places the vertices) and may change the materials. :meth:`render` draws a
    :class:`Frame` and returns its image; :meth:`draw` and :meth:`read` split that in two, so
    that the caller can work while the frame is drawn. The context comes from :func:`start`.
    """

    def __init__(self, width: int, height: int, *, vertices: np.ndarray, normals: np.ndarray, part: np.ndarray,
                 indices: np.ndarray, n_lights: int) -> None:
        self.width, self.height = int(width), int(height)
        self.n_vertices = len(vertices)
        self.n_parts = int(np.max(part)) + 1
        self.n_lights = int(n_lights)
        self.pyrender, self._offscreen, self.platform = start(self.width, self.height)
        self._objects: dict[str, list] = {}
        self._materials = None
        self._drawn = None  # the box of the frame drawn and not read yet
        try:
            static = np.concatenate([vertices, normals, np.asarray(part, np.float64)[:, None]], axis=1)
            self._build(np.ascontiguousarray(static, np.float32), np.ascontiguousarray(indices, dtype=np.uint32))
        except BaseException:
            self.delete()
            raise

    def _build(self, static: np.ndarray, indices: np.ndarray) -> None:
        from OpenGL import GL
        from OpenGL.GL import shaders

        self._offscreen._platform.make_current()
        self.n_indices = int(indices.size)
        self._program = shaders.compileProgram(
            shaders.compileShader(_VERTEX_SHADER.format(n_parts=self.n_parts), GL.GL_VERTEX_SHADER),
            shaders.compileShader(_FRAGMENT_SHADER.format(n_lights=self.n_lights), GL.GL_FRAGMENT_SHADER),
            validate=False)
        self._objects["program"] = [self._program]
        self._uniforms = {name: GL.glGetUniformLocation(self._program, name)
                          for name in ("VP", "parts", "cam_pos", "ambient_light", "light_direction", "light_radiance")}
        self._vao = GL.glGenVertexArrays(1)
        self._objects["vertex arrays"] = [self._vao]
        GL.glBindVertexArray(self._vao)
        vbo, self._material_vbo, ibo = buffers = list(GL.glGenBuffers(3))
        self._objects["buffers"] = buffers
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, vbo)  # position, normal, part: fixed
        GL.glBufferData(GL.GL_ARRAY_BUFFER, static.nbytes, static, GL.GL_STATIC_DRAW)
        for loc, size, offset in ((0, 3, 0), (1, 3, 12), (3, 1, 24)):
            GL.glVertexAttribPointer(loc, size, GL.GL_FLOAT, GL.GL_FALSE, 28, ctypes.c_void_p(offset))
            GL.glEnableVertexAttribArray(loc)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, self._material_vbo)
        GL.glBufferData(GL.GL_ARRAY_BUFFER, self.n_vertices * 4 * 4, None, GL.GL_DYNAMIC_DRAW)
        GL.glVertexAttribPointer(2, 4, GL.GL_FLOAT, GL.GL_FALSE, 16, ctypes.c_void_p(0))
        GL.glEnableVertexAttribArray(2)
        GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, ibo)
        GL.glBufferData(GL.GL_ELEMENT_ARRAY_BUFFER, indices.nbytes, indices, GL.GL_STATIC_DRAW)
        GL.glBindVertexArray(0)
        # A multisampled framebuffer to draw in, a plain one to resolve it into and read back.
        color_ms, depth_ms, color = self._objects["renderbuffers"] = list(GL.glGenRenderbuffers(3))
        self._framebuffers = self._objects["framebuffers"] = list(GL.glGenFramebuffers(2))
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, color_ms)
        GL.glRenderbufferStorageMultisample(GL.GL_RENDERBUFFER, SAMPLES, GL.GL_RGBA8, self.width, self.height)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, depth_ms)
        GL.glRenderbufferStorageMultisample(GL.GL_RENDERBUFFER, SAMPLES, GL.GL_DEPTH_COMPONENT24, self.width, self.height)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, color)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_RGBA8, self.width, self.height)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self._framebuffers[0])
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0, GL.GL_RENDERBUFFER, color_ms)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT, GL.GL_RENDERBUFFER, depth_ms)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self._framebuffers[1])
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0, GL.GL_RENDERBUFFER, color)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        GL.glUseProgram(self._program)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glEnable(GL.GL_CULL_FACE)
        GL.glCullFace(GL.GL_BACK)
        GL.glEnable(GL.GL_MULTISAMPLE)
        GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
        GL.glViewport(0, 0, self.width, self.height)

    def render(self, frame: Frame, region: tuple[int, int, int, int] | None = None) -> np.ndarray:
        """Draw ``frame``; returns the image (H, W, 3) uint8, top row first: only the pixel box
        ``region`` (x0, y0, x1, y1 from the top left, inside the picture) when given."""
        self.draw(frame, region)
        return self.read()

    def draw(self, frame: Frame, region: tuple[int, int, int, int] | None = None) -> None:
        """Start drawing ``frame`` (the GL works on while this returns); :meth:`read` gives it.
        With ``region`` only that box is drawn (a scissor: what is outside costs nothing) and
        read, its pixels the same as in the whole picture."""
        from OpenGL import GL

        parts = np.asarray(frame.parts, np.float64)
        if parts.shape != (self.n_parts, 4, 4):
            raise ValueError(f"parts are {parts.shape}, expected {(self.n_parts, 4, 4)}")
        if len(frame.lights) != self.n_lights:
            raise ValueError(f"{len(frame.lights)} lights, expected {self.n_lights}")
        x0, y0, x1, y1 = region if region is not None else (0, 0, self.width, self.height)
        if not (0 <= x0 < x1 <= self.width and 0 <= y0 < y1 <= self.height):
            raise ValueError(f"region {region} is not inside the {self.width}x{self.height} picture")
        self._offscreen._platform.make_current()
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self._framebuffers[0])
        if region is not None:  # GL's rows count from the bottom
            GL.glEnable(GL.GL_SCISSOR_TEST)
            GL.glScissor(x0, self.height - y1, x1 - x0, y1 - y0)
        else:
            GL.glDisable(GL.GL_SCISSOR_TEST)
        GL.glClearColor(*(c / 255 for c in frame.background), 1.0)
        GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
        u = self._uniforms
        GL.glUniformMatrix4fv(u["VP"], 1, GL.GL_TRUE, np.ascontiguousarray(frame.view_projection, np.float32))
        GL.glUniform4fv(u["parts"], 3 * self.n_parts, np.ascontiguousarray(parts[:, :3, :], np.float32))
        GL.glUniform3fv(u["cam_pos"], 1, np.asarray(frame.eye, np.float32))
        GL.glUniform3fv(u["ambient_light"], 1, np.asarray(frame.ambient, np.float32))
        GL.glUniform3fv(u["light_direction"], self.n_lights, np.asarray([d for d, _ in frame.lights], np.float32))
        GL.glUniform3fv(u["light_radiance"], self.n_lights, np.asarray([r for _, r in frame.lights], np.float32))
        GL.glBindVertexArray(self._vao)
        if frame.materials is not self._materials:
            materials = np.ascontiguousarray(frame.materials, dtype=np.float32)
            if materials.shape != (self.n_vertices, 4):
                raise ValueError(f"materials are {materials.shape}, expected {(self.n_vertices, 4)}")
            GL.glBindBuffer(GL.GL_ARRAY_BUFFER, self._material_vbo)
            GL.glBufferSubData(GL.GL_ARRAY_BUFFER, 0, materials.nbytes, materials)
            self._materials = frame.materials
        GL.glDrawElements(GL.GL_TRIANGLES, self.n_indices, GL.GL_UNSIGNED_INT, ctypes.c_void_p(0))
        GL.glBindVertexArray(0)
        GL.glFlush()
        self._drawn = (x0, y0, x1, y1)

    def read(self) -> np.ndarray:
        """The image of the last :meth:`draw` (H, W, 3) uint8, top row first (waits for it)."""
        from OpenGL import GL

        if not self._drawn:
            raise RuntimeError("read() before draw()")
        x0, y0, x1, y1 = self._drawn
        self._drawn = None
        w, h, bottom = x1 - x0, y1 - y0, self.height - y1
        ms, resolved = self._framebuffers
        self._offscreen._platform.make_current()
        GL.glDisable(GL.GL_SCISSOR_TEST)  # the blit is clipped by the scissor too
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, ms)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, resolved)
        GL.glBlitFramebuffer(x0, bottom, x1, bottom + h, x0, bottom, x1, bottom + h, GL.GL_COLOR_BUFFER_BIT, GL.GL_LINEAR)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, resolved)
        raw = GL.glReadPixels(x0, bottom, w, h, GL.GL_RGB, GL.GL_UNSIGNED_BYTE)
        return np.frombuffer(raw, dtype=np.uint8).reshape(h, w, 3)[::-1]

    def delete(self) -> None:
        """Release the GL objects and the context (best effort: a broken GL stack raises
        anything here, and it must not hide the render's own result or error)."""
        offscreen, self._offscreen = getattr(self, "_offscreen", None), None
        if offscreen is None:
            return
        try:
            from OpenGL import GL

            offscreen._platform.make_current()
            deleters = {"framebuffers": GL.glDeleteFramebuffers, "renderbuffers": GL.glDeleteRenderbuffers,
                        "buffers": GL.glDeleteBuffers, "vertex arrays": GL.glDeleteVertexArrays}
            for kind, names in self._objects.items():
                if kind == "program":
                    GL.glDeleteProgram(names[0])
                else:
                    deleters[kind](len(names), names)
        except Exception:  # noqa: BLE001 - see the docstring
            pass
        try:
            offscreen.delete()
        except Exception:  # noqa: BLE001 - see the docstring
            pass
