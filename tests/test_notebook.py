"""The example notebook runs from top to bottom, and nodes and meshes show themselves in it."""

from dataclasses import replace
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="the test extra installs nbformat")
nbclient = pytest.importorskip("nbclient", reason="the test extra installs nbclient")

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "shell_step_by_step.ipynb"


@pytest.mark.slow
def test_example_notebook_runs_and_shows_pictures_and_a_viewer(tmp_path):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    shown = [out.get("data", {}) for cell in nb.cells if cell.cell_type == "code"
             for out in cell.get("outputs", []) if out.output_type == "execute_result"]
    pictures = [d for d in shown if "image/png" in d]
    viewers = [d for d in shown if "<iframe" in d.get("text/html", "")]
    assert len(pictures) == 4  # generating surface, whorl, varix, shell
    assert len(viewers) == 1 and "base64_data" in viewers[0]["text/html"]


def test_a_node_and_a_mesh_display_themselves():
    import io

    import numpy as np
    from PIL import Image

    import blobtree as bt

    node = bt.Point(radius=1.0).color((0.8, 0.2, 0.2))
    img = np.asarray(Image.open(io.BytesIO(node._repr_png_())))
    assert img.shape[:2] == (bt.api.PREVIEW_SIZE, bt.api.PREVIEW_SIZE)
    red = (img[..., 0] > 1.5 * img[..., 1]) & (img[..., 0] > 60)
    assert 0.2 < red.mean() < 0.8  # the red ball, framed, on the backdrop
    html = bt.polygonize(node, resolution=16)._repr_html_()
    assert html.startswith("<iframe srcdoc=") and "&lt;!DOCTYPE html&gt;" in html
    assert "no triangles" in bt.Mesh.empty()._repr_html_()


def test_shown_keeps_the_tree_and_carries_how_to_look_at_it():
    import blobtree as bt

    tree = bt.Point(radius=1.0)
    seen = tree.shown(up=(0, -1, 0), view=(1, 0, 0))
    assert seen == tree and seen is not tree
    assert seen.display == ((0.0, -1.0, 0.0), (1.0, 0.0, 0.0))
    assert tree.display == ((0.0, 1.0, 0.0), None)
    assert bt.models.murex(textured=False).display[0] == (0.0, -1.0, 0.0)  # apex up
    with pytest.raises(ValueError, match="non-zero"):
        tree.shown(up=(0, 0, 0))
    with pytest.raises(ValueError, match="view"):
        tree.shown(view=(0, float("nan"), 0))


LIVE = NOTEBOOK.with_name("live_shell.ipynb")


@pytest.mark.slow
def test_the_live_notebook_shows_the_explorer_and_saves_a_spec(tmp_path):
    pytest.importorskip("ipywidgets", reason="the test extra installs ipywidgets")
    import blobtree as bt

    nb = nbformat.read(LIVE, as_version=4)
    for cell in nb.cells:  # small pictures: the test is about the notebook, not the shell
        cell.source = cell.source.replace("size=384", "size=64, coarse=32, settle=0.0")
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    shown = [out.get("data", {}) for cell in nb.cells if cell.cell_type == "code"
             for out in cell.get("outputs", []) if out.output_type == "execute_result"]
    assert "application/vnd.jupyter.widget-view+json" in shown[0]  # the explorer's widgets
    assert shown[1]["text/plain"] == "40.0"
    saved = bt.models.load_spec(tmp_path / "my_murex.toml")
    assert saved == replace(bt.models.SHELLS["murex"], canal_tilt=40.0)
