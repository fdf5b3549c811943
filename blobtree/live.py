"""Modelling live: a shell drawn again as its spec changes, coarse first, then sharper.

:class:`LiveShell` keeps the trees, programs and framing points of the specs it drew last, so
that going back to a spec, or turning the view, only renders, and compiles a changed spec's
tree copying the instructions of the subtrees the change left alone; :func:`explore` puts it beside
ipywidgets controls in a notebook, and ``blobtree watch`` (``cli/watch_cmd.py``) beside a file
an editor saves (docs/live.md).
"""

from __future__ import annotations

import contextlib
import gc
import math
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import models
from .checks import Choice, Integer, Kind, Number, short_repr
from .engine.program import Reuse, compile_tree
from .helico import KINDS as SPIRAL_KINDS
from .helico import HelicoSpiral
from .models.parts import Parts
from .models.spec import FIELDS, SPIRAL_KEYS, Flag, Numbers, ShellSpec, to_toml
from .nodes.node import drop_older_frames, mark_frames
from .output import write_file
from .render import LOOKS, Stopped, local_tiles, render, stop_flag, warm_kernels
from .render.camera import Camera, frame_points, surface_points
from .render.image import encode_png
from .runtime.threads import threads as parallel_threads

#: How far the view turns about the shell axis and tilts toward its apex, in degrees.
TURN, TILT = Number(-180.0, 180.0), Number(-80.0, 80.0)
#: Vertical field of view of the pictures, degrees (a shell's own view, as ``render`` frames it).
FOV = 30.0
#: Specs whose tree, program and framing points are kept: dragging back costs only a render.
KEPT = 8
#: The first picture of a change, drawn while a control moves: no shadow rays, and a whole
#: pixel as a camera ray's smallest step (the sharp pictures take half a pixel; on the Murex at
#: 128x128, 39 of 16,384 pixels then differ by more than 8 levels, and the render takes 0.6
#: to 0.8 times as long: docs/live.md).
DRAFT: dict[str, Any] = {"shadows": False, "step": 1.0}
#: Seconds between glimpses of a sharp picture being drawn: its tiles finished so far, shown over
#: the draft of the same change scaled to its size.
GLIMPSE = 0.25
#: Deflate level of a glimpse's PNG: the fastest (a 512 studio picture of the Murex: 10 ms at
#: level 1, 23 ms at 6, on the AMD EPYC of docs/live.md).
GLIMPSE_PNG = 1


@dataclass(frozen=True)
class View:
    """Where the shell is seen from: its own view (``look.view``, ``look.up``) turned by
    ``turn`` degrees about the shell axis, then tilted ``tilt`` degrees toward the apex."""

    turn: float = 0.0
    tilt: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "turn", TURN.check("turn", self.turn))
        object.__setattr__(self, "tilt", TILT.check("tilt", self.tilt))

    def direction(self, up: tuple, view: tuple) -> tuple[float, ...]:
        """The direction looked along: ``view`` turned about ``up``, then tilted toward it."""
        u = np.asarray(up, float) / np.linalg.norm(up)
        v = np.asarray(view, float) / np.linalg.norm(view)
        t = math.radians(self.turn)  # Rodrigues' rotation about u
        v = v * math.cos(t) + np.cross(u, v) * math.sin(t) + u * (u @ v) * (1 - math.cos(t))
        flat = v - u * (u @ v)  # the tilt is measured from the plane across the axis
        flat /= np.linalg.norm(flat)
        a = math.radians(self.tilt) + math.asin(float(np.clip(u @ v, -1.0, 1.0)))
        a = float(np.clip(a, math.radians(-85.0), math.radians(85.0)))
        return tuple(float(x) for x in flat * math.cos(a) - u * math.sin(a))


@dataclass
class _Built:
    tree: Any
    prog: Any
    points: np.ndarray


class LiveShell:
    """Pictures of a shell spec as it changes.  :meth:`picture` builds what the spec and seed
    need (the tree, its program, the points framing it), keeping the last ``KEPT`` of them,
    and renders; ``timings`` holds the seconds each part of the last picture took."""

    def __init__(self, spec: ShellSpec | Mapping | str | Path = "murex", seed: int = 0) -> None:
        self.spec = models.load_spec(spec)
        self.seed = Integer(0, 2**32 - 1).check("seed", seed)
        self._kept: OrderedDict[tuple[ShellSpec, int], _Built] = OrderedDict()
        #: the subtrees of the last program compiled, copied into the next (a change
        #: compiles only the parts it touches)
        self._reuse = Reuse()
        #: the parts of the shells built, handed back where a change leaves them as they were
        self._parts = Parts(KEPT)
        #: the memos by frame :meth:`tidy` marked
        self._marked: list[dict] = []
        self.timings: dict[str, float] = {}

    def set(self, spec: ShellSpec | None = None, seed: int | None = None) -> bool:
        """Take a new spec and/or seed; True if either differs from the one in hand."""
        spec = self.spec if spec is None else models.load_spec(spec)
        seed = self.seed if seed is None else Integer(0, 2**32 - 1).check("seed", seed)
        changed = (spec, seed) != (self.spec, self.seed)
        self.spec, self.seed = spec, seed
        return changed

    def _built(self, key: tuple[ShellSpec, int]) -> _Built:
        built = self._kept.get(key)
        if built is not None:
            self._kept.move_to_end(key)
            self.timings.update(tree=0.0, program=0.0, framing=0.0)
            return built
        t0 = time.perf_counter()
        tree = models.shell(*key, parts=self._parts)
        t1 = time.perf_counter()
        prog = compile_tree(tree, self._reuse)
        t2 = time.perf_counter()
        points = surface_points(prog)
        self.timings.update(tree=t1 - t0, program=t2 - t1, framing=time.perf_counter() - t2)
        built = self._kept[key] = _Built(tree, prog, points)
        while len(self._kept) > KEPT:
            self._kept.popitem(last=False)
        return built

    def tidy(self) -> None:
        """Forget the frames the nodes of the last tree built keep boxes and maps for (their
        memos by frame) that no compile asked for since the last tidy (call it while idle: a
        few milliseconds).  The pieces of the parts kept are placed anew at each change of
        the spiral, each time in new frames: without this, their memos would gather a frame
        a change (1.1 MB a change of the Murex's spiral), without end."""
        drop_older_frames(self._marked)
        self._marked = []
        if self._kept:
            self._marked = mark_frames(next(reversed(self._kept.values())).tree.unique())

    def camera(self, width: int, height: int, view: View = View()) -> Camera:
        """The camera framing the shell in a width x height picture seen from ``view``."""
        return self._camera(self._built((self.spec, self.seed)), width, height, view)

    def _camera(self, built: _Built, width: int, height: int, view: View) -> Camera:
        up, along = built.tree.display
        return frame_points(built.points, width / height, view.direction(up, along), up, FOV)

    def picture(self, width: int, height: int, view: View = View(), **options: Any
                ) -> np.ndarray:
        """The shell seen from ``view``: an (height, width, 3) uint8 image; ``options`` go to
        :func:`blobtree.render.render` (``shadows``, ``look``, ``samples``, ``background``)."""
        self.timings = {}
        with _collector_held():
            built = self._built((self.spec, self.seed))  # (one spec, though another thread sets)
            camera = self._camera(built, width, height, view)
            t0 = time.perf_counter()
            img = render(built.prog, width, height, camera=camera, **options)
        self.timings["render"] = time.perf_counter() - t0
        return img


@contextlib.contextmanager
def _collector_held() -> Iterator[None]:
    """Python's cycle collector held off while a picture is made: a build makes tens of
    thousands of objects, and the collections they start walk them (a few milliseconds each)
    and, every few builds, every object kept (0.11 s with the Murex's eight builds kept: one
    first picture in twelve took one); after the picture the collector runs as it would have
    (the explorer also collects fully while idle).  Another thread's picture may end the hold
    early: collections then run as usual."""
    held = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if held:
            gc.enable()


# ----- the notebook explorer --------------------------------------------------------------------
#: Spec keys without a control: the variable-length tables (edit them in the file) and the
#: view's basis (the view controls turn and tilt about it).
NO_CONTROL = ("name", "varices.table", "canal_spines.table", "varices.tori", "look.up",
              "look.view")


def slider_range(kind: Number | Integer, value: float) -> tuple[float, float]:
    """The span of a slider for a value of ``kind``: the kind's whole range when it is narrow
    (angles, fractions, counts up to 100), else the part of it within a few times the value,
    where a modeller looks (the rest stays reachable in the file)."""
    lo, hi = kind.lo, kind.hi
    if isinstance(kind, Integer):
        return (lo, hi) if hi - lo <= 100 else (lo, min(hi, max(2 * value, lo + 24)))
    if hi - lo <= 720.0:
        return lo, hi
    span = max(3.0 * abs(value), 1.0)
    return max(lo, value - span), min(hi, value + span)


def _controls_of(spec: ShellSpec) -> dict[str, tuple[str, Kind, Any]]:
    """Each control's name -> (table, kind, value): a number per slider (a list of numbers
    gives one per item, ``canal.base[0]``), a colour per picker, a flag per box, a choice per
    menu."""
    out: dict[str, tuple[str, Kind, Any]] = {}
    for key in SPIRAL_KEYS:
        value = getattr(spec.spiral, key)
        if value is not None:  # (d_ratio None: computed from Eq. 3)
            out[f"spiral.{key}"] = ("spiral", SPIRAL_KINDS[key], value)
    for key, f in FIELDS.items():
        if key in NO_CONTROL:
            continue
        table, kind, value = key.split(".")[0], f.metadata["kind"], getattr(spec, f.name)
        if isinstance(kind, Numbers):
            for i, v in enumerate(value):
                out[f"{key}[{i}]"] = (table, kind.item, v)
        else:
            out[key] = (table, kind, value)
    return out


def with_control(spec: ShellSpec, name: str, value: Any) -> ShellSpec:
    """``spec`` with the control ``name`` (a key of ``Explorer.controls``) set to ``value``; a
    ValueError naming the key if the spec refuses it."""
    key, _, index = name.partition("[")
    if key.startswith("spiral."):
        return replace(spec, spiral=_spiral_with(spec.spiral, key.split(".")[1], value))
    if key not in FIELDS or key in NO_CONTROL:
        raise ValueError(f"control must be one of {sorted(_controls_of(spec))}, got "
                         f"{short_repr(name)}")
    f = FIELDS[key]
    if key == "whorls.count" and isinstance(value, int) and value >= 1:
        # Table 1 keeps a row per whorl: the last rows dropped, or the last repeated
        rows = spec.table_1[:value] + spec.table_1[-1:] * (value - len(spec.table_1))
        return replace(spec, whorls=value, table_1=rows)
    if index:
        items = list(getattr(spec, f.name))
        items[int(index.rstrip("]"))] = value
        value = tuple(items)
    return replace(spec, **{f.name: value})


def _spiral_with(spiral: HelicoSpiral, key: str, value: Any) -> HelicoSpiral:
    try:
        return replace(spiral, **{key: value})
    except ValueError as e:
        raise ValueError(f"spiral.{e}") from None


def _hex(rgb: tuple) -> str:
    return "#" + "".join(f"{round(c * 255):02x}" for c in rgb)


def _rgb(text: str) -> tuple[float, float, float]:
    text = text.lstrip("#")
    return tuple(int(text[i:i + 2], 16) / 255.0 for i in (0, 2, 4))


def _widget(widgets: Any, name: str, kind: Kind, value: Any) -> Any:
    """The ipywidgets control for a value of ``kind``."""
    label = name.split(".", 1)[-1]
    style = {"description_width": "9em"}
    common = dict(description=label, style=style, continuous_update=True,
                  layout=widgets.Layout(width="26em"))
    if isinstance(kind, Flag):
        return widgets.Checkbox(value=value, description=label, style=style)
    if isinstance(kind, Choice):
        return widgets.Dropdown(options=list(kind.options), value=value, description=label,
                                style=style)
    if isinstance(kind, Numbers):  # a colour
        return widgets.ColorPicker(value=_hex(value), description=label, style=style)
    lo, hi = slider_range(kind, value)
    if isinstance(kind, Integer):
        return widgets.IntSlider(value=value, min=lo, max=hi, **common)
    return widgets.FloatSlider(value=value, min=lo, max=hi, step=(hi - lo) / 1000.0,
                               readout_format=".4g", **common)


class Explorer:
    """A shell beside controls for its spec (see :func:`explore`).  ``controls`` maps each
    spec key (``"canal.tilt"``, ``"whorls.point_scale[1]"``, ``"spiral.beta"``) and ``"seed"``,
    ``"turn"``, ``"tilt"``, ``"look"`` to its widget; ``spec`` is the spec in hand; ``image``
    the picture; ``pictures`` counts the pictures drawn."""

    def __init__(self, spec: ShellSpec | Mapping | str | Path = "murex", seed: int = 0,
                 size: int = 512, coarse: int = 128, settle: float = 0.0,
                 path: str | Path | None = None) -> None:
        import ipywidgets as widgets

        self.live = LiveShell(spec, seed)
        self.size = Integer(16, 4096).check("size", size)
        self.coarse = Integer(16, self.size).check("coarse", coarse)
        self.settle = Number(0.0, 60.0).check("settle", settle)
        self.view, self.look = View(), "studio"
        self.pictures = 0
        self._error: str | None = None
        default = path or (spec if isinstance(spec, str | Path) and Path(spec).suffix == ".toml"
                           else f"{Path(str(self.live.spec.name)).name.replace(' ', '_')}.toml")
        self.image = widgets.Image(format="png", layout=widgets.Layout(width=f"{self.size}px"))
        self.status = widgets.HTML()
        self.path = widgets.Text(value=str(default), description="file")
        save = widgets.Button(description="save TOML", icon="save")
        save.on_click(lambda _: self._report(self.save))
        self.controls: dict[str, Any] = {
            "seed": widgets.BoundedIntText(value=self.live.seed, min=0, max=2**32 - 1,
                                           description="seed"),
            "turn": widgets.FloatSlider(value=0.0, min=TURN.lo, max=TURN.hi, step=1.0,
                                        description="turn"),
            "tilt": widgets.FloatSlider(value=0.0, min=TILT.lo, max=TILT.hi, step=1.0,
                                        description="tilt"),
            "look": widgets.Dropdown(options=sorted(LOOKS), value=self.look, description="look"),
        }
        tables: dict[str, list] = {}
        for name, (table, kind, value) in _controls_of(self.live.spec).items():
            self.controls[name] = _widget(widgets, name, kind, value)
            tables.setdefault(table, []).append(self.controls[name])
        for name, control in self.controls.items():
            control.observe(lambda change, name=name: self._changed(name, change["new"]),
                            names="value")
        accordion = widgets.Accordion(children=[widgets.VBox(c) for c in tables.values()],
                                      titles=tuple(tables))
        head = [self.controls[k] for k in ("turn", "tilt", "look", "seed")]
        side = widgets.VBox([*head, widgets.HBox([self.path, save]), self.status, accordion])
        self.widget = widgets.HBox([self.image, side])
        self._cond = threading.Condition()
        self._wanted = self._drawn = 0  # generations asked for and fully drawn
        self._shown: tuple[int, np.ndarray | None] = (0, None)  # the last picture, its generation
        self._stop = stop_flag()  # set to stop the picture being drawn
        self._closed = False
        self._thread = threading.Thread(target=self._draw_loop, name="blobtree-explore",
                                        daemon=True)
        self._thread.start()
        self._request()

    @property
    def spec(self) -> ShellSpec:
        """The spec in hand."""
        return self.live.spec

    def _repr_mimebundle_(self, **options: Any) -> dict | None:
        """Shown in a notebook as its widgets."""
        return self.widget._repr_mimebundle_(**options)

    def _changed(self, name: str, value: Any) -> None:
        """A control moved: a new spec, seed or view, drawn at once; a refused value is shown
        and the picture kept."""
        try:
            if name == "seed":
                changed = self.live.set(seed=value)
            elif name in ("turn", "tilt"):
                view = replace(self.view, **{name: value})
                changed, self.view = view != self.view, view
            elif name == "look":
                changed, self.look = value != self.look, Choice(tuple(LOOKS)).check("look", value)
            else:
                if isinstance(self.controls[name], _color_picker()):
                    value = _rgb(value)
                changed = self.live.set(with_control(self.live.spec, name, value))
        except ValueError as e:
            self._show_status(f"⚠ {e}")
            return
        if changed:
            self._request()

    def _request(self) -> None:
        with self._cond:
            self._wanted += 1
            self._stop[0] = 1  # the picture being drawn ends at its next packet of pixels
            self._cond.notify_all()

    @property
    def passes(self) -> list[tuple[int, dict[str, Any]]]:
        """(side, options) of the pictures drawn for a change: a ``coarse`` draft (``DRAFT``)
        at once, then ``size`` with shadows once nothing changes, shown as its tiles finish."""
        return [(self.coarse, DRAFT), (self.size, {})]

    def _stale(self, generation: int) -> bool:
        return self._wanted != generation or self._closed

    def _draw_loop(self) -> None:
        """The drawing thread: the latest change's :attr:`passes`, the sharper ones once nothing
        has changed for ``settle`` seconds; a change stops the picture being drawn.  Going idle,
        it collects garbage: a full collection walks every tree kept (0.06-0.35 s), and Python
        starts one once the objects made since the last have grown by a quarter, which the
        builds of two or three changes do; collected while idle, it falls in no picture.  What
        survives is then frozen (``gc.freeze``: left out of later collections, until
        :meth:`close`), so the next idle collection walks only what the changes since made: a
        change set just as the explorer goes idle waited for the whole walk (0.06-0.1 s of
        the Murex's kept builds) before its draft.  The kept builds make no reference cycles
        (such a collection finds nothing to free); a frozen object is still freed once
        nothing refers to it."""
        while True:
            with self._cond:
                idle = self._wanted == self._drawn and not self._closed
            if idle:  # (outside the lock: a control moved meanwhile is not held up)
                self.live.tidy()
                gc.collect()
                gc.freeze()
            with self._cond:
                while self._wanted == self._drawn and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                generation = self._wanted
            for i, (side, options) in enumerate(self.passes):
                if i == 1:
                    with self._cond:
                        self._cond.wait_for(lambda g=generation: self._stale(g), self.settle)
                if self._stale(generation) or not self._draw(side, options, generation, i > 0):
                    break
            with self._cond:
                if not self._stale(generation) or self._closed:
                    self._drawn = generation
                    self._cond.notify_all()

    def _draw(self, size: int, options: dict[str, Any], generation: int,
              stoppable: bool) -> bool:
        """Draw one pass (stopped by a change if ``stoppable``); False if it is not worth going
        on (a refused spec, or stale)."""
        try:
            img = self.live.picture(size, size, self.view, look=self.look,
                                    source=self._tiles(generation, stoppable), **options)
        except (_Stale, Stopped):
            return False
        except ValueError as e:
            self._show_status(f"⚠ {e}")
            return False
        self.image.value = encode_png(img)
        self._shown = (generation, img)
        self.pictures += 1
        self._show_status(f"{size}x{size}: " + ", ".join(
            f"{k} {v:.2f} s" for k, v in self.live.timings.items()))
        return True

    def _tiles(self, generation: int, stoppable: bool = True) -> Callable[..., Iterator]:
        """``render``'s tile source: this machine's, the tiles nearest the centre first (the
        shell); if ``stoppable``, stopped by a change (:meth:`_request` sets ``local_tiles``'
        stop flag: the tiles being traced end at their next packet of pixels, the others are
        dropped), else drawn whole (a draft: while a slider is dragged, each draft finished
        shows the shell following it).  Once a picture of the same change is shown, every
        ``GLIMPSE`` seconds the tiles finished so far are shown over it, scaled, and their
        count under the buttons."""

        def source(prog: Any, camera: Camera, lights: list, settings: Any,
                   rects: list) -> Iterator:
            w, h = settings.width, settings.height
            rects = sorted(rects, key=lambda r: (r[0] + r[2] - w) ** 2 + (r[1] + r[3] - h) ** 2)
            glimpse = self._glimpse(generation, w, h)
            last = time.perf_counter()
            stop = stop_flag()
            if stoppable:
                with self._cond:  # a change from here on stops this picture's tiles
                    if self._stale(generation):
                        raise _Stale
                    self._stop = stop
            with contextlib.closing(local_tiles(prog, camera, lights, settings, rects,
                                                parallel_threads(), stop)) as done:
                for finished, item in enumerate(done, 1):
                    if glimpse is not None:
                        (x0, y0, x1, y1), pixels = item
                        glimpse[y0:y1, x0:x1] = pixels
                        if time.perf_counter() - last >= GLIMPSE:
                            self.image.value = encode_png(glimpse, GLIMPSE_PNG)
                            self._show_status(f"{w}x{h}: {finished} of {len(rects)} tiles")
                            last = time.perf_counter()
                    yield item

        return source

    def _glimpse(self, generation: int, width: int, height: int) -> np.ndarray | None:
        """The picture shown, scaled to width x height, if it is of this change (else None:
        another shell's tiles would be mixed in)."""
        from PIL import Image  # (lazily, as render.image does)

        shown, img = self._shown  # (generations start at 1: none is shown as of 0)
        if shown != generation:
            return None
        return np.array(Image.fromarray(img).resize((width, height), Image.Resampling.BILINEAR))

    def _show_status(self, text: str) -> None:
        import html

        self.status.value = f"<small>{html.escape(text)}</small>"

    def _report(self, action: Callable[[], Any]) -> None:
        try:
            self._show_status(f"wrote {action()}")
        except (ValueError, OSError) as e:
            self._show_status(f"⚠ {e}")

    def wait(self, timeout: float = 300.0) -> bool:
        """Wait until the latest change is drawn at full size (or refused); False if
        ``timeout`` seconds passed first."""
        with self._cond:
            return self._cond.wait_for(lambda: self._drawn == self._wanted, timeout)

    def save(self, path: str | Path | None = None) -> Path:
        """Write the spec in hand as TOML (``blobtree spec``'s form) to ``path`` (default: the
        file box's); return the path."""
        target = Path(self.path.value if path is None else path)
        if target.suffix != ".toml":
            raise ValueError(f"path must end in .toml, got {short_repr(str(target))}")
        return write_file(target, to_toml(self.spec).encode("utf-8"))

    def close(self) -> None:
        """Stop the drawing thread and close the widgets."""
        with self._cond:
            self._closed = True
            self._stop[0] = 1
            self._cond.notify_all()
        self._thread.join()
        self.widget.close()
        gc.unfreeze()  # (what the drawing thread froze is collected as usual again)


class _Stale(Exception):
    """A picture given up: the controls changed while it was drawn."""


def _color_picker() -> type:
    import ipywidgets

    return ipywidgets.ColorPicker


def explore(spec: ShellSpec | Mapping | str | Path = "murex", seed: int = 0, size: int = 512,
            **options: Any) -> Explorer:
    """A shell beside controls for its spec, in a notebook: sliders for its numbers (over the
    ranges their kinds allow), menus for its choices, grouped by the spec's tables, and the
    view (turn about the shell axis, tilt toward the apex).  A change draws a coarse draft
    at once (``DRAFT``: no shadows, a whole pixel as the smallest step), then, once
    nothing has changed for ``settle`` seconds, the studio picture with shadows at ``size``
    pixels, shown as its tiles finish (a change stops it; a draft is always finished, so a
    dragged slider shows the shell following it);
    "save TOML" writes the spec; ``explorer.spec`` is the spec in hand.

    ``spec``: a shipped shell's name, a path to a TOML spec, its data or a ShellSpec;
    ``options``: ``coarse`` (side of the first picture, 128), ``settle`` (0 s), ``path``
    (the file "save TOML" writes).  Needs ipywidgets (``pip install blobtree[explore]``)."""
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        raise ImportError("bt.explore needs ipywidgets: pip install 'blobtree[explore]'") from None
    unknown = sorted(set(options) - {"coarse", "settle", "path"})
    if unknown:
        raise ValueError(f"explore takes coarse, settle and path, got {unknown}")
    warm_kernels()  # (loading, on a first run compiling, while the tree is built)
    return Explorer(spec, seed, size, **options)


__all__ = ["DRAFT", "Explorer", "LiveShell", "View", "explore", "slider_range", "with_control"]
