"""A mesh as one self-contained HTML page with an orbit viewer (three.js, as trimesh ships it).

The page embeds the coloured mesh as a GLB and the whole viewer (trimesh's page template,
``trimesh.viewer.notebook.scene_to_html``): it loads nothing from the network, so it opens
offline and can be mailed.  On top of trimesh's page it sets a matte material (glTF's default is
fully metallic, which renders nearly black without an environment map), a sky light so shaded
sides keep their colour, a soft background, and a camera that looks at the model with its
``up`` up, framed as the ray tracer frames it.
"""

from __future__ import annotations

import base64
import json
import os
import struct
from pathlib import Path

import numpy as np

from ..geometry import axis_vector, rotation_onto
from ..output import write_file
from ..render.camera import frame_points
from .export import Mesh, Y, import_trimesh

#: Default view: a three-quarter view from slightly above.
VIEW = (-0.6, -0.35, -0.72)
#: The page's aspect for framing (the viewer adapts to its window).
ASPECT = 1.5

#: Runs before the viewer: records script errors on ``<body data-errors>``.
_BEFORE = """<script>
window.addEventListener("error", function (e) {
  document.body.dataset.errors = (document.body.dataset.errors || "") + e.message + "\\n";
});
</script>"""

#: Runs after the viewer's set-up: lights and background; ``<body data-ready>`` once the model
#: is on screen.
_AFTER = """<script>
scene.background = new THREE.Color(0xeeeff2);
scene.add(new THREE.HemisphereLight(0xffffff, 0x6a6560, 0.45));
tracklight.intensity = 0.8;
(function wait() {
  if (scene.children.length > 2 && camera) {
    document.body.dataset.ready = "1";
  } else {
    setTimeout(wait, 50);
  }
})();
</script>"""


def _matte_glb(glb: bytes) -> bytes:
    """The GLB with a matte, non-metallic material on every primitive."""
    (json_len,) = struct.unpack_from("<I", glb, 12)
    doc = json.loads(glb[20:20 + json_len])
    rest = glb[20 + json_len:]
    doc["materials"] = [{"pbrMetallicRoughness": {"metallicFactor": 0.0,
                                                  "roughnessFactor": 0.65}}]
    for mesh in doc.get("meshes", []):
        for prim in mesh["primitives"]:
            prim["material"] = 0
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def page(mesh: Mesh, up: tuple[float, float, float] = (0.0, 1.0, 0.0),
         view: tuple[float, float, float] | None = None, title: str = "blobtree") -> str:
    """The mesh as a self-contained HTML page: an orbit viewer (drag to turn, wheel to zoom,
    right-drag to pan) showing it in its own colours with ``up`` up, first seen along ``view``
    (a direction in the mesh's frame; by default a three-quarter view from above)."""
    if len(mesh.faces) == 0:
        raise ValueError("the mesh has no triangles: nothing to show")
    trimesh = import_trimesh()
    from trimesh.viewer.notebook import scene_to_html

    rot = rotation_onto(axis_vector(up, "up"), Y)
    turned = mesh.turned(up)
    scene = trimesh.Scene(turned.to_trimesh())
    look = VIEW if view is None else rot @ np.asarray(view, dtype=np.float64)
    cam = frame_points(turned.vertices[:: max(1, len(turned.vertices) // 20000)], ASPECT,
                       tuple(look), fov=35.0)
    fwd, right, cam_up = cam.basis()
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, cam_up, -fwd, cam.eye
    # named: trimesh would draw a random name, and the page would change from run to run
    scene.camera = trimesh.scene.Camera(name="camera", fov=(35.0 * ASPECT, 35.0))
    scene.camera_transform = pose
    html = scene_to_html(scene)
    # the GLB travels base64-encoded inside the page: give it a matte material
    start = html.index('base64_data="') + len('base64_data="')
    end = html.index('"', start)
    glb = _matte_glb(base64.b64decode(html[start:end]))
    html = html[:start] + base64.b64encode(glb).decode() + html[end:]
    html = html.replace("<title>trimesh: threejs viewer</title>", f"<title>{title}</title>", 1)
    html = html.replace("<body>", "<body>" + _BEFORE, 1)
    return html.replace("</body>", _AFTER + "</body>", 1)


def save_page(mesh: Mesh, path: str | os.PathLike, **options) -> Path:
    """Write :func:`page` to ``path`` as :func:`blobtree.output.write_file` writes (``-``:
    standard output; a regular file whole or not at all)."""
    return write_file(path, page(mesh, **options).encode("utf-8"))
