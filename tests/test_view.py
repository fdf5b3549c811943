"""The 3D page (``blobtree view``), checked in a real headless browser (Chromium, software
WebGL): it loads without script errors, offline, and shows the model up-side up in its colours."""

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import blobtree as bt
from blobtree.cli.main import main
from blobtree.mesh.web import page, save_page

BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")
needs_browser = pytest.mark.skipif(BROWSER is None, reason="no Chromium on this machine "
                                   "(.ci/run installs the Debian package)")
FLAGS = ["--headless=new", "--no-sandbox", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--virtual-time-budget=10000", "--window-size=400,400",
         # no host resolves: the page must not need the network
         "--host-resolver-rules=MAP * ~NOTFOUND"]


def two_balls():
    """A red ball above (+y) a blue one."""
    red = bt.Point(radius=1.0).translate(0.0, 0.8, 0.0).color((0.9, 0.1, 0.1))
    blue = bt.Point(radius=1.0).translate(0.0, -0.8, 0.0).color((0.1, 0.2, 0.9))
    return bt.union(red, blue)


def browse(url: str, tmp: Path) -> tuple[str, np.ndarray]:
    """The page's DOM after loading, and its screenshot (RGB)."""
    dom = subprocess.run([BROWSER, *FLAGS, "--dump-dom", url], capture_output=True, text=True,
                         timeout=120).stdout
    shot = tmp / "shot.png"
    subprocess.run([BROWSER, *FLAGS, f"--screenshot={shot}", url], capture_output=True,
                   timeout=120, check=True)
    return dom, np.asarray(Image.open(shot).convert("RGB")).astype(int)


def rows_of(img: np.ndarray, colour: str) -> np.ndarray:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    mask = (r > 120) & (r > 2 * g) & (r > 2 * b) if colour == "red" else \
        (b > 120) & (b > 2 * r) & (b > g + 40)
    return np.nonzero(mask)[0]


@needs_browser
@pytest.mark.parametrize("up", [(0.0, 1.0, 0.0), (0.0, -1.0, 0.0)])
def test_page_loads_and_shows_the_model_up_side_up_in_its_colours(tmp_path, up):
    mesh = bt.polygonize(two_balls(), resolution=40)
    path = save_page(mesh, tmp_path / "balls.html", up=up)
    dom, img = browse(path.as_uri(), tmp_path)
    assert 'data-ready="1"' in dom, "the model never reached the screen"
    assert "data-errors" not in dom, re.findall(r'data-errors="([^"]*)"', dom)
    red, blue = rows_of(img, "red"), rows_of(img, "blue")
    # both balls are on screen in their own colours (not black: lit, matte)
    assert len(red) > 500 and len(blue) > 500
    # the one on the +up side is higher in the picture
    if up[1] > 0:
        assert red.mean() < blue.mean() - 40
    else:
        assert blue.mean() < red.mean() - 40


def test_page_is_one_file_that_loads_nothing_from_the_network(tmp_path):
    html = page(bt.polygonize(two_balls(), resolution=16))
    assert not re.search(r'<script[^>]+src=|<link[^>]+href=|<img[^>]+src=', html)
    assert "base64_data=\"Z2xURg" in html  # the GLB ("glTF") is inside
    with pytest.raises(ValueError, match="no triangles"):
        page(bt.polygonize(bt.Point(radius=1.0), resolution=16, bounds=((5, 5, 5), (6, 6, 6))))
    with pytest.raises(ValueError, match="up must be"):
        page(bt.polygonize(two_balls(), resolution=16), up=(0.0, 0.0, 0.0))


def test_view_command_writes_the_page(tmp_path):
    scene = tmp_path / "balls.json"
    bt.save(two_balls(), scene)
    out = tmp_path / "v.html"
    r = CliRunner().invoke(main, ["view", str(scene), "-o", str(out), "-r", "24"])
    assert r.exit_code == 0, r.output
    assert "MB" in r.output and out.read_text().startswith("<!DOCTYPE html>")
    r = CliRunner().invoke(main, ["view", str(scene), "-o", str(tmp_path / "no" / "v.html")])
    assert r.exit_code != 0 and "does not exist" in r.output
