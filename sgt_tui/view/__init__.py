"""``sgt view``: a take in 3D in a web page, served on this machine (docs/view.md).

- :mod:`.page`: what the page shows, as data: each speaker's joints and hand joints per frame,
  the words and controls on the performance clock, sgt's cameras and lights; the speech as one
  WAV; a speaker's motion as VRM Animation;
- :mod:`.takes`: what is viewed (a script, a motion file, a build folder), loaded again when its
  files change;
- :mod:`.server`: the ASGI application of ``sgt view`` (the page, its data, the token);
- :mod:`.service`: the same page offered by ``sgt serve`` to its clients;
- ``static/``: the page (index.html, viewer.css) and the vendored bundle (viewer.js: three.js,
  three-vrm and three-vrm-animation with the page's code, built from ``viewer/`` by esbuild).
"""
