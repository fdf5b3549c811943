"""Benchmark: the direct ray tracer against POV-Ray's blob on the whorl126 scene.

Renders whorl126 at 800x800 and 1600x1600 (one light, no anti-aliasing, the same framing) with
POV-Ray and with blobtree, both as whole processes from the command line, and with blobtree also
in-process after warm-up: without shadows, and with shadows on both sides (the same parallel
light).  Then times ``blobtree render murex --size 1024x1024`` (the default look: textures, shadows)
as a whole process against POV-Ray's whorl126 at the largest size.  Prints times and ratios, the
numba compile cost (a run with an empty cache), the bars (the most each ratio to POV-Ray may be),
and saves the images side by side.  With ``--record`` the figures are appended to
bench/results.jsonl (see bench/record.py; ``python bench/report.py`` then regenerates
docs/benchmarks.md).

    python bench/bench_render.py [--sizes 800,1600] [--repeat 3] [--murex 1024] [--out bench/out]
                                 [--record] [--record-file PATH]

POV-Ray's blob component field is strength (1 - r^2/radius^2)^2.  With radius 2D it is
strength * (3/4)^2 = 0.5625 strength at r = D, so strength 0.5 / 0.5625 puts the 0.5 iso-surface
of a lone component at r = D, the visible radius of our Point(radius=2).scale(D).  Our scene is
right-handed and POV-Ray's left-handed: mirroring z in both scene and camera gives the same image.
"""

from __future__ import annotations

import argparse
import compileall
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import record
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import blobtree as bt  # noqa: E402
from blobtree.helico import MUREX_SPIRAL  # noqa: E402
from blobtree.models.yardstick import THETA_S  # noqa: E402
from blobtree.render import Camera, render  # noqa: E402
from blobtree.render.camera import default_camera  # noqa: E402
from blobtree.render.shade import default_lights  # noqa: E402

ALBEDO = 0.8  # blobtree's default grey, an sRGB value


def whorl_centres() -> tuple[np.ndarray, np.ndarray]:
    """Centres and visible radii D of the 126 instances (Eq. 8 applied to the origin)."""
    centres, sizes = [], []
    for i in range(126):
        theta = i * THETA_S
        r, h, d = (MUREX_SPIRAL.radius(theta), MUREX_SPIRAL.height(theta),
                   MUREX_SPIRAL.size(theta))
        a = math.radians(theta)  # right-hand rotation about y of (r, h, 0)
        centres.append((r * math.cos(a), h, -r * math.sin(a)))
        sizes.append(d)
    return np.array(centres), np.array(sizes)


def pov_scene(camera: Camera, light_dir: np.ndarray, width: int, height: int,
              shadows: bool = False) -> str:
    """The POV-Ray scene: one blob, camera and parallel light (casting shadows or not), with z
    mirrored."""
    def v(p) -> str:
        return f"<{p[0]:.9g}, {p[1]:.9g}, {-p[2]:.9g}>"

    aspect = width / height
    hfov = math.degrees(2 * math.atan(math.tan(math.radians(camera.fov) / 2) * aspect))
    target = np.array(camera.target)
    lin = ((ALBEDO + 0.055) / 1.055) ** 2.4
    centres, sizes = whorl_centres()
    comps = "\n".join(f"  sphere {{ {v(c)}, {2 * d:.9g}, {0.5 / 0.5625:.9g} }}"
                      for c, d in zip(centres, sizes, strict=True))
    return f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 ambient_light rgb 1 }}
background {{ rgb 1 }}
camera {{ perspective location {v(camera.eye)} look_at {v(target)} sky y
         up y right x * {aspect:.9g} angle {hfov:.9g} }}
light_source {{ {v(target - 1000.0 * light_dir)} color rgb 1 parallel point_at {v(target)}
               {"" if shadows else "shadowless"} }}
blob {{ threshold 0.5
{comps}
  pigment {{ rgb {lin:.6g} }}
  finish {{ ambient 0.12 diffuse 1 specular 0.25 roughness 0.025 }}
}}
"""


def timed(cmd: list[str], env: dict | None = None) -> float:
    """Wall time of a whole process (raises if it fails)."""
    start = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return time.perf_counter() - start


def pov_version(povray: str) -> str:
    """POV-Ray's name and major.minor version, e.g. ``POV-Ray 3.7``."""
    out = subprocess.run([povray, "--version"], capture_output=True, text=True)
    found = re.search(r"POV-Ray (\d+\.\d+)", out.stdout + out.stderr)
    return f"POV-Ray {found[1]}" if found else "POV-Ray"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="800,1600")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--murex", type=int, default=1024, help="size of the Murex render (0: skip)")
    ap.add_argument("--out", default=str(ROOT / "bench" / "out"))
    record.add_arguments(ap)
    args = ap.parse_args()
    record_file = record.target(args)
    sizes = [int(s) for s in args.sizes.split(",")]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    povray = shutil.which("povray")
    if povray is None:
        sys.exit("povray not found: apt-get install -y povray")

    prog = bt.models.whorl126().program()
    centres, _ = whorl_centres()
    assert np.all(prog.field(centres) > 0.99), "POV-Ray centres do not match whorl126"
    camera = default_camera(prog, 800, 800)  # square images share this framing
    light_dir = np.array(default_lights(camera)[0].direction)
    cam_opts = ["--eye", ",".join(map(repr, camera.eye)),
                "--target", ",".join(map(repr, camera.target)), "--fov", repr(camera.fov)]
    # an installed package has its bytecode compiled (pip does it): without this, where
    # PYTHONDONTWRITEBYTECODE is set, every process would compile ~70 modules (~0.2 s)
    compileall.compile_dir(ROOT / "blobtree", quiet=1)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cache = tempfile.mkdtemp(prefix="blobtree-numba-")
    env["NUMBA_CACHE_DIR"] = cache

    def ours(size: int, path: Path, shadows: bool) -> list[str]:
        return [sys.executable, "-m", "blobtree.cli.main", "render", "whorl126", "-o", str(path),
                "--size", f"{size}x{size}", "--look", "paper", "--quiet", *cam_opts,
                *([] if shadows else ["--no-shadows"])]

    rows = []
    cold = timed(ours(sizes[0], out / "cold.png", False), env)  # empty numba cache: compiles
    for shadows in (False, True):
        tag = "shadows" if shadows else "noshadows"
        for size in sizes:
            pov_file = out / f"whorl126_{size}_{tag}.pov"
            pov_file.write_text(pov_scene(camera, light_dir, size, size, shadows))
            pov_png = out / f"whorl126_{size}_{tag}_povray.png"
            our_png = out / f"whorl126_{size}_{tag}_blobtree.png"
            pov_cmd = [povray, f"+I{pov_file}", f"+O{pov_png}", f"+W{size}", f"+H{size}", "-D",
                       "-A", "+FN", "-GA", "File_Gamma=sRGB", f"+WT{os.cpu_count()}"]
            t_pov = t_cli = math.inf
            for _ in range(args.repeat):  # alternated: a machine whose speed drifts during
                t_pov = min(t_pov, timed(pov_cmd))  # the run weighs on both sides alike
                t_cli = min(t_cli, timed(ours(size, our_png, shadows), env))
            # the paper look: one light, plain background, as the POV-Ray scene
            render(prog, 64, 64, camera=camera, shadows=shadows, look="paper")  # warm-up
            t_in = math.inf
            for _ in range(args.repeat):
                start = time.perf_counter()
                img = render(prog, size, size, camera=camera, shadows=shadows, look="paper")
                t_in = min(t_in, time.perf_counter() - start)
            assert (img == np.asarray(Image.open(our_png))).all(), "CLI, in-process differ"
            side = np.concatenate([np.asarray(Image.open(pov_png).convert("RGB")), img], axis=1)
            Image.fromarray(side).save(out / f"whorl126_{size}_{tag}_povray_vs_blobtree.png")
            rows.append((shadows, size, t_pov, t_cli, t_in))
    t_murex = math.inf
    if args.murex:
        murex_cmd = [sys.executable, "-m", "blobtree.cli.main", "render", "murex", "-o",
                     str(out / f"murex_{args.murex}.png"), "--size", f"{args.murex}x{args.murex}",
                     "--quiet"]
        t_murex = min(timed(murex_cmd, env) for _ in range(args.repeat))
    shutil.rmtree(cache, ignore_errors=True)

    print(f"whorl126, 1 light, no AA; best of {args.repeat}; {os.cpu_count()} cores")
    print(f"{'shadows':>8} {'size':>10} {'POV-Ray':>9} {'blobtree CLI':>13} {'ratio':>6} "
          f"{'in-process':>11} {'ratio':>6}")
    for shadows, size, t_pov, t_cli, t_in in rows:
        print(f"{'on' if shadows else 'off':>8} {size:>5}x{size:<4} {t_pov:>8.2f}s "
              f"{t_cli:>12.2f}s {t_cli / t_pov:>6.2f} {t_in:>10.3f}s {t_in / t_pov:>6.2f}")
    warm = next(t_cli for shadows, size, _, t_cli, _ in rows if size == sizes[0] and not shadows)
    print(f"numba compile cost (first run, empty cache): {cold:.2f}s - {warm:.2f}s = "
          f"{cold - warm:.2f}s")
    # the bars: whole processes against POV-Ray at the largest size
    big = max(sizes)
    pov = {shadows: t_pov for shadows, size, t_pov, _, _ in rows if size == big}
    cli = {shadows: t_cli for shadows, size, _, t_cli, _ in rows if size == big}
    bars = [(f"whorl126 {big}, no shadows: CLI", cli[False] / pov[False], 0.5),
            (f"whorl126 {big}, shadows: CLI", cli[True] / pov[True], 0.7)]
    if args.murex:
        print(f"murex {args.murex}x{args.murex} (default look, shadows), whole command: "
              f"{t_murex:.2f}s")
        bars.append((f"murex {args.murex} over POV-Ray's whorl126 {big} (no shadows)",
                     t_murex / pov[False], 5.0))
    for name, ratio, limit in bars:
        verdict = "PASS" if ratio <= limit else "FAIL"
        print(f"bar {name} <= {limit}x POV-Ray: {ratio:.2f}x {verdict}")
    print(f"images: {out}")
    if record_file:
        peer = pov_version(povray)
        note = f"best of {args.repeat}"
        first = f"whorl126 render {sizes[0]}x{sizes[0]}, whole command, no shadows"
        recorded = [record.row(f"{first}, empty numba cache", cold,
                               note="one run: compiles the kernels")]
        for shadows, size, t_pov, t_cli, t_in in rows:
            name = f"whorl126 render {size}x{size}, %s, {'shadows' if shadows else 'no shadows'}"
            recorded += [record.row(name % "whole command", t_cli, peer, t_pov, note),
                         record.row(name % "in-process", t_in, peer, t_pov,
                                    f"{note}; {peer} as a whole command")]
        if args.murex:
            m = args.murex
            recorded.append(record.row(f"murex render {m}x{m}, whole command, default look",
                                       t_murex, f"{peer}, whorl126 {big}x{big}, no shadows",
                                       pov[False], note))
        record.append("bench_render.py", recorded, record_file)
        print(f"recorded in {record_file}")


if __name__ == "__main__":
    main()
