"""isoview: isosurfaces of interpolated scalar fields, rendered with Vulkan compute.

Renders and extracts the isosurface of a 3-D numpy array, of a volume file, or of an isoview
scene file, with the library the ``isoview`` command line is built on (no subprocess, no
temporary file)::

    >>> import numpy as np, isoview
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> volume = x**2 + y**2 + z**2                   # [i, j, k] is the value at (x_i, y_j, z_k)
    >>> image = isoview.render(volume, 0.5, width=64, height=64)
    >>> image.rgba.shape, image.depth.dtype
    ((64, 64, 4), dtype('float32'))
    >>> verts, faces, normals, values = isoview.extract(volume, 0.5, method="lorensen")

Arrays follow scikit-image's conventions: index order ``[i, j, k] = (x, y, z)``, ``spacing``
per axis, and the object is where the values are *above* the level (``inside="above"``; pass
``inside="below"`` for signed distances). The distribution is ``isoview-vulkan`` (PyPI's
``isoview`` is an unrelated microscopy project); the documentation is ``docs/python.md``.
"""

from __future__ import annotations

import collections
import json
import math
import os

import numpy as np

from . import _isoview as _native
from ._isoview import GpuError, NoDeviceError

__all__ = [
    "Scene",
    "Image",
    "Mesh",
    "CompareReport",
    "render",
    "extract",
    "probe",
    "slice",
    "stats",
    "compare",
    "GpuError",
    "NoDeviceError",
    "AOVS",
]

__version__ = _native.version()

#: The AOVs an :class:`Image` can hold: name -> the EXR channels stacked in its last axis (one
#: channel: an array of shape (height, width); several: (height, width, channels)).
AOVS = {
    "rgba": ("R", "G", "B", "A"),
    "depth": ("Z",),
    "normal": ("N.X", "N.Y", "N.Z"),
    "position": ("P.X", "P.Y", "P.Z"),
    "steps": ("steps",),
    "cell": ("cell.X", "cell.Y", "cell.Z"),
    "crossings": ("crossings",),
    "iso_index": ("iso_index",),
    "color_value": ("color.value",),
}

#: scikit-image's names of the extraction methods, as isoview calls them.
_MESH_ALIASES = {"lorensen": "marching-cubes", "lewiner": "mc33"}

#: Data files a path may name besides a scene (``.toml``): ``.npy``, and what
#: ``[field] source = "file"`` reads (the format from the extension).
_FILE_SUFFIXES = (
    ".nrrd", ".nhdr", ".nii", ".nii.gz", ".mrc", ".map", ".ccp4", ".mha", ".mhd", ".vti",
    ".vtk", ".tif", ".tiff",
)


def _toml(value):
    """``value`` in TOML syntax, as ``--set KEY=VALUE`` takes it."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, (str, os.PathLike)):
        return json.dumps(os.fspath(value))  # a TOML basic string: JSON's escapes are TOML's
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    raise ValueError(f"{value!r}: not a value a scene key takes (numbers, strings, booleans, "
                     "lists and dicts)")


def _key(k):
    k = str(k)
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def _flatten(prefix, value, out):
    """``--set`` overrides ``prefix.key=value`` for every leaf of a dict of scene keys."""
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    else:
        out.append(f"{prefix}={_toml(value)}")


def _number(name, value):
    """``value`` as a float, or a ValueError naming the keyword ``name`` (Python's own
    message names neither)."""
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None


def _whole(name, value):
    """``value`` as an int, or a ValueError naming the keyword ``name``."""
    try:
        if isinstance(value, float) and not value.is_integer():
            raise ValueError
        return int(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected a whole number, got {value!r}") from None


def _vec3(name, value):
    # A string is iterable (its characters), never three numbers.
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name}: expected 3 numbers (x, y, z), got {value!r}")
    try:
        v = [float(x) for x in value]
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected 3 numbers (x, y, z), got {value!r}") from None
    if len(v) != 3:
        raise ValueError(f"{name}: expected 3 numbers (x, y, z), one per axis, got {len(v)}")
    if not all(math.isfinite(x) for x in v):
        raise ValueError(f"{name}: must be finite numbers, got {v}")
    return v


class Scene:
    """A validated isoview scene: a scene file with its ``--set`` overrides, or a field over an
    array or a data file with the keys keyword arguments gave.

    Every function that takes a volume takes a Scene; keyword arguments left unset keep the
    scene's own values, and those given are applied as the CLI's ``--set`` would apply them.

        >>> scene = isoview.Scene.from_toml("scenes/torus.toml", set=["render.steps=64"])
        >>> scene.method, scene.width
        ('analytic', 512)
        >>> image = isoview.render(scene)     # the CLI's `isoview render scenes/torus.toml ...`
    """

    def __init__(self, native):
        self._native = native

    @classmethod
    def from_toml(cls, path, set=()):
        """Loads the scene file at ``path`` with ``set`` (``"KEY=VALUE"`` strings, TOML values)
        applied as the CLI's ``--set``. Raises ``ValueError`` with the CLI's one-line message
        (``FILE:LINE:COL: KEY: what is wrong``)."""
        return cls(_native.scene_from_toml(os.fspath(path), _sets(set)))

    def with_set(self, *sets):
        """This scene with further ``--set`` overrides, e.g.
        ``scene.with_set("render.method=fixed-step", "render.steps=64")``."""
        return Scene(self._native.with_sets([], _sets(sets)))

    def to_toml(self):
        """The scene file's text with its overrides written in: a file that loads to this
        scene (relative data paths stay relative to the original's folder). Scenes over an
        array or a data file have no file and raise ``ValueError``."""
        return self._native.to_toml()

    path = property(lambda self: self._native.path, doc="The scene file (None: none).")
    sets = property(lambda self: self._native.sets, doc="The overrides applied, in order.")
    width = property(lambda self: self._native.width)
    height = property(lambda self: self._native.height)
    isovalue = property(lambda self: self._native.isovalue)
    isovalues = property(lambda self: self._native.isovalues)
    method = property(lambda self: self._native.method, doc="render.method")
    mesh = property(lambda self: self._native.mesh, doc="render.mesh")
    inside = property(lambda self: self._native.inside, doc="surface.inside")
    resolution = property(lambda self: tuple(self._native.resolution))
    bounds = property(lambda self: self._native.bounds, doc="(min, max) of the grid's box")
    field = property(lambda self: self._native.field, doc="The field, as EXR headers say it.")
    channels = property(lambda self: self._native.channels,
                        doc="The EXR channels a render of this scene writes.")

    def __repr__(self):
        where = f"{os.fspath(self.path)!r}" if self.path is not None else "in memory"
        return (f"<isoview.Scene {where}: {self.field}, isovalue {self.isovalue}, "
                f"{self.method}, {self.width}x{self.height}>")


def _sets(sets):
    if isinstance(sets, str):
        sets = [sets]
    return [str(s) for s in sets]


def _scene(volume, keyword, sets, spacing=None, origin=None, camera=None):
    """The scene for ``volume`` (a Scene, an array, or a path) with the keyword overrides
    ``keyword`` (``KEY=VALUE``) and the user's ``sets``."""
    sets = _sets(sets)
    if isinstance(volume, Scene):
        if spacing is not None or origin is not None:
            raise ValueError("spacing and origin apply to arrays and data files; a scene's box "
                             "is field.bounds (e.g. set=[\"field.bounds.min=[0, 0, 0]\"])")
        if camera is not None:
            _flatten("camera", dict(camera), keyword)
        if not keyword and not sets:
            return volume._native
        return volume._native.with_sets(keyword, sets)
    if isinstance(volume, (str, os.PathLike)) and (spacing is not None or origin is not None):
        raise ValueError("spacing and origin apply to arrays; a data file's header gives its "
                         "box (set field.bounds to override it)")
    if camera is None:
        keyword.insert(0, "camera.fit=true")  # frame the whole grid box
    else:
        _flatten("camera", dict(camera), keyword)
    if isinstance(volume, (str, os.PathLike)):
        path = os.path.abspath(os.fspath(volume))
        low = path.lower()
        if low.endswith(".npy"):
            source = "npy"
        elif low.endswith(_FILE_SUFFIXES):
            source = "file"
        else:
            raise ValueError(f"{os.fspath(volume)}: not a file isoview reads by its name (a "
                             "scene .toml, .npy, or a volume file: "
                             f"{', '.join(_FILE_SUFFIXES)}); write a scene for raw files")
        text = f"[field]\nsource = \"{source}\"\npath = {_toml(path)}\n"
        return _native.scene_from_text(text, os.path.dirname(path), keyword, sets)
    array = np.asarray(volume)
    _native.check_array_shape([int(n) for n in array.shape])  # the cap, before any copy
    if array.ndim == 3 and not (array.flags.c_contiguous or array.flags.f_contiguous):
        array = np.ascontiguousarray(array)  # strided views: one copy into C order
    box = []
    if spacing is not None or origin is not None:
        box = _array_box(array.shape, spacing, origin)
    return _native.scene_from_array(array, box + keyword, sets)


def _array_box(shape, spacing, origin):
    """``field.bounds`` of an array of ``shape`` with point [i, j, k] at origin + index *
    spacing."""
    s = _vec3("spacing", (1.0, 1.0, 1.0) if spacing is None else spacing)
    o = _vec3("origin", (0.0, 0.0, 0.0) if origin is None else origin)
    if not all(x > 0 for x in s):
        raise ValueError(f"spacing: must be positive, got {s}")
    if len(shape) != 3:
        return []  # the module refuses the shape in its own words
    hi = [o[a] + s[a] * (shape[a] - 1) for a in range(3)]
    return [f"field.bounds.min={_toml(o)}", f"field.bounds.max={_toml(hi)}"]


def _common(keyword, isovalue=None, inside=None, interpolation=None, width=None, height=None,
            scene_keys=None, array_like=False, isovalue_name="isovalue"):
    if isovalue is not None:
        keyword.append(f"surface.isovalue={_toml(_number(isovalue_name, isovalue))}")
    if inside is None and array_like:
        inside = "above"  # scikit-image's convention for arrays
    if inside is not None:
        keyword.append(f"surface.inside={_toml(str(inside))}")
    if interpolation is not None:
        keyword.append(f"field.interpolation={_toml(str(interpolation))}")
    if width is not None:
        keyword.append(f"image.width={_toml(width)}")
    if height is not None:
        keyword.append(f"image.height={_toml(height)}")
    for table, value in (scene_keys or {}).items():
        _flatten(table, value, keyword)


def _is_array_like(volume):
    """An array or a data file (not a Scene): scikit-image's defaults apply."""
    return not isinstance(volume, Scene)


def _as_input(volume):
    """A path to a scene file as a :class:`Scene` (the path as given, so that its EXR names
    it as the CLI's does); anything else as it is."""
    if isinstance(volume, (str, os.PathLike)) and os.fspath(volume).lower().endswith(".toml"):
        return Scene.from_toml(volume)
    return volume


class Image:
    """A rendered frame: numpy arrays per AOV, the PNG preview, the CLI's EXR.

    ``image.rgba`` (height, width, 4), ``image.depth`` (height, width), ``image.normal``
    (height, width, 3), ... for each AOV asked for (:data:`AOVS`), float32, row 0 at the top;
    ``image["N.X"]`` for any EXR channel the render wrote. In a notebook the image shows
    itself (``_repr_png_``).

        >>> image = isoview.render(volume, 0.5, aovs=("rgba", "depth", "position"))
        >>> hit = np.isfinite(image.depth)          # the pixels whose ray met the surface
        >>> image.save_exr("out.exr")               # what `isoview render` writes
    """

    def __init__(self, native, aovs):
        self._native = native
        self.channels = tuple(native.channels)
        self.aovs = {}
        for name in aovs:
            if name not in AOVS:
                raise ValueError(f"aov {name!r}: expected one of {', '.join(AOVS)}")
            missing = [c for c in AOVS[name] if c not in self.channels]
            if missing:
                raise ValueError(f"aov {name!r}: this render writes no {', '.join(missing)} "
                                 f"channel (it writes {', '.join(self.channels)})")
            planes = [native.channel(c) for c in AOVS[name]]
            self.aovs[name] = planes[0] if len(planes) == 1 else np.stack(planes, axis=-1)

    width = property(lambda self: self._native.width)
    height = property(lambda self: self._native.height)

    def __getattr__(self, name):
        aovs = self.__dict__.get("aovs", {})
        if name in aovs:
            return aovs[name]
        if name in AOVS:
            raise AttributeError(f"aov {name!r} was not asked for: render(..., aovs=(..., "
                                 f"{name!r}))")
        raise AttributeError(name)

    def __getitem__(self, name):
        """An AOV asked for, or any EXR channel of the render by name (``"N.X"``)."""
        if name in self.aovs:
            return self.aovs[name]
        if name in self.channels:
            return self._native.channel(name)
        raise KeyError(f"{name!r}: the AOVs are {', '.join(self.aovs)}; the channels "
                       f"{', '.join(self.channels)}")

    def channel(self, name):
        """EXR channel ``name`` as a float32 array of shape (height, width)."""
        return self[name] if name in self.channels else self._native.channel(name)

    def save_exr(self, path):
        """Writes the EXR ``isoview render`` writes for this scene, byte for byte: every
        channel of :attr:`channels`, the header that says how it was made (written whole or
        not at all)."""
        self._native.save_exr(os.fspath(path))

    def png(self):
        """The 8-bit sRGB PNG preview of the beauty (the CLI's ``--png``), as bytes."""
        return self._native.png()

    def _repr_png_(self):
        return self.png()

    @property
    def summary(self):
        """The render's summary, as a dict: device, method, ms (the whole call), gpu_ms."""
        device, method, ms, gpu_ms = self._native.summary()
        return {"device": device, "method": method, "ms": ms, "gpu_ms": gpu_ms}

    def __repr__(self):
        s = self.summary
        return (f"<isoview.Image {self.width}x{self.height} {s['method']} on {s['device']}, "
                f"aovs {', '.join(self.aovs)}>")


def render(volume, isovalue=None, *, spacing=None, origin=None, camera=None, width=None,
           height=None, method=None, interpolation=None, inside=None, aovs=None, time=0.0,
           set=(), **scene_keys):
    """Renders the isosurface of ``volume`` at ``isovalue``; returns an :class:`Image`.

    ``volume``: a 3-D numpy array (any real, integer or boolean dtype, C or Fortran order;
    element ``[i, j, k]`` is the value at grid point ``(x_i, y_j, z_k)``, as in scikit-image),
    a path to a scene (``.toml``) or to a data file the CLI reads (``.npy``, NRRD, NIfTI, MRC,
    MetaImage, VTK, TIFF), or a :class:`Scene`.

    For arrays and data files the defaults are isoview's scene defaults (isovalue 0.0,
    512 x 512, ``method="analytic"``, ``interpolation="trilinear"``) with the camera fitted to
    the grid's box and the object where values are above the isovalue (``inside="above"``).
    For a Scene, every keyword left unset keeps the scene's own value.

    - ``spacing``, ``origin``: the grid's box for an array (point ``[i, j, k]`` at
      ``origin + (i, j, k) * spacing``).
    - ``camera``: a dict of ``[camera]`` keys, e.g. ``{"eye": [3, 2, 3], "target": [0, 0, 0],
      "fov_y_deg": 30}`` or ``{"fit": True, "projection": "orthographic"}``; None fits the box.
    - ``method``: ``"analytic"``, ``"fixed-step"`` or ``"mesh"``; ``interpolation``:
      ``"trilinear"``, ``"cubic-bspline"``, ``"catmull-rom"``, ``"nearest"``, ``"device"``.
    - ``aovs``: names from :data:`AOVS`; default ``("rgba", "depth", "normal")`` for arrays,
      every channel group the render writes for a Scene.
    - ``set``: ``"KEY=VALUE"`` overrides as the CLI's ``--set``; ``**scene_keys``: any other
      scene key as a dict per table, e.g. ``render={"shading": "normal", "steps": 64}``.

    Raises ``ValueError`` for bad input (the CLI's one-line message), ``NoDeviceError`` when
    no Vulkan device can be opened, ``GpuError`` when the GPU fails. The GIL is released
    while the field is sampled and rendered.

        >>> image = isoview.render(volume, 0.5, spacing=(0.1, 0.1, 0.2), width=256, height=256,
        ...                        render={"shading": "normal"})
    """
    volume = _as_input(volume)
    keyword = []
    if method is not None:
        keyword.append(f"render.method={_toml(str(method))}")
    _common(keyword, isovalue, inside, interpolation, width, height, scene_keys,
            _is_array_like(volume))
    native = _scene(volume, keyword, set, spacing, origin, camera)
    frame = _native.render(native, _number("time", time))
    if aovs is None:
        if isinstance(volume, Scene):
            written = frame.channels
            aovs = [n for n, cs in AOVS.items() if all(c in written for c in cs)]
        else:
            aovs = ("rgba", "depth", "normal")
    elif isinstance(aovs, str):
        aovs = (aovs,)
    return Image(frame, aovs)


class Mesh(collections.namedtuple("Mesh", "verts faces normals values")):
    """``(verts, faces, normals, values)`` as ``skimage.measure.marching_cubes`` returns
    them: verts (V, 3) float32 in index order times ``spacing`` (plus ``origin``), faces
    (F, 3) int32, normals (V, 3) float32 unit, values (V,) float32. Unpacks and slices as a
    tuple (``verts, faces = mesh[:2]``).

    ``values`` is scikit-image's "maximum value of the data in the local region near each
    vertex" by its rule: the largest range of the 8 corner samples (minus the level) over the
    grid cells that hold the vertex. ``surface`` gives each vertex's surface index (scenes
    with several isovalues), ``ran_on`` where the extraction ran.
    """

    # No __slots__: a Mesh also carries `surface` (each vertex's surface index) and `ran_on`.
    surface = None
    ran_on = None

    def to_trimesh(self, **kwargs):
        """A ``trimesh.Trimesh`` of the mesh (``process=False``: vertex order kept)."""
        try:
            import trimesh
        except ImportError:
            raise ImportError("to_trimesh needs trimesh: pip install trimesh") from None
        return trimesh.Trimesh(self.verts, self.faces, vertex_normals=self.normals,
                               process=False, **kwargs)

    def to_pyvista(self):
        """A ``pyvista.PolyData`` of the mesh, with ``Normals`` and ``values`` point data."""
        try:
            import pyvista
        except ImportError:
            raise ImportError("to_pyvista needs pyvista: pip install pyvista") from None
        faces = np.column_stack([np.full(len(self.faces), 3, dtype=np.int64),
                                 self.faces.astype(np.int64)]).ravel()
        poly = pyvista.PolyData(np.asarray(self.verts, dtype=np.float32), faces)
        poly.point_data["Normals"] = self.normals
        poly.point_data["values"] = self.values
        return poly


def _mesh(verts, faces, normals, values, surface, ran_on):
    mesh = Mesh(verts, faces, normals, values)
    mesh.surface, mesh.ran_on = surface, ran_on
    return mesh


def extract(volume, level=None, *, spacing=None, origin=None, method=None,
            inside=None, interpolation=None, device="auto", time=0.0, set=(), **scene_keys):
    """Extracts the isosurface of ``volume`` at ``level`` as a mesh with scikit-image's
    conventions; returns a :class:`Mesh` ``(verts, faces, normals, values)``.

    Drops into code written for ``skimage.measure.marching_cubes``: the object is where the
    values are above ``level`` (``inside="above"``, its default orientation; normals point out
    of it, faces counter-clockwise seen from outside), ``verts`` are in index order times
    ``spacing``, and ``method="lorensen"`` (isoview's ``"marching-cubes"``, the default) gives
    the same triangle count and the same vertices as scikit-image's plain marching cubes (in
    another order: isoview numbers vertices by lattice edge, x fastest). ``level=None`` is the
    middle of the data's range, as in scikit-image.

    ``method``: ``"marching-cubes"`` (``"lorensen"``), ``"mc33"`` (``"lewiner"``),
    ``"surface-nets"``, ``"dual-contouring"``, ``"marching-tetrahedra"``, ...
    (``render.mesh``'s names). ``device``: ``"auto"`` (the CPU on lavapipe), ``"cpu"``,
    ``"gpu"``. ``volume``, ``set`` and ``**scene_keys`` as for :func:`render`; ``method``
    defaults to ``"marching-cubes"``, and for a Scene ``level`` and ``method`` left unset keep
    its ``surface.isovalue`` and ``render.mesh``.

        >>> from skimage import measure
        >>> verts, faces, normals, values = isoview.extract(volume, 0.5)   # was measure.marching_cubes
        >>> mesh = isoview.extract(volume, 0.5, spacing=(1, 1, 2.5))
        >>> mesh.to_trimesh().is_watertight  # doctest: +SKIP
    """
    volume = _as_input(volume)
    keyword = []
    if method is None and not isinstance(volume, Scene):
        method = "marching-cubes"
    if method is not None:
        keyword.append(f"render.mesh={_toml(_MESH_ALIASES.get(str(method), str(method)))}")
    if level is None and not isinstance(volume, (Scene, str, os.PathLike)):
        a = np.asarray(volume)
        _native.check_array_shape([int(n) for n in a.shape])  # the cap, before the copy
        if a.ndim == 3 and a.size and a.dtype.kind in "biuf":
            a = a.astype(np.float32)
            level = (float(np.nanmin(a)) + float(np.nanmax(a))) / 2.0
    _common(keyword, level, inside, interpolation, None, None, scene_keys,
            _is_array_like(volume), isovalue_name="level")
    native = _scene(volume, keyword, set, spacing, origin, None)
    verts, faces, normals, values, surface, ran_on = _native.extract(native, str(device),
                                                                     _number("time", time))
    return _mesh(verts, faces, normals, values, surface, ran_on)


def probe(volume, pixel, isovalue=None, *, time=0.0, set=(), **kwargs):
    """What the ray through ``pixel = (x, y)`` (row 0 at the top) meets, as ``isoview probe
    --pixel X,Y --json`` reports it (a dict; a list of them with several isovalues): the
    cells the exact walk visits, the cubic along each, the roots and their Newton iterates,
    and where fixed-step finds its crossing. Other arguments as for :func:`render`."""
    volume = _as_input(volume)
    keyword = []
    camera = kwargs.pop("camera", None)
    spacing, origin = kwargs.pop("spacing", None), kwargs.pop("origin", None)
    _common(keyword, isovalue, kwargs.pop("inside", None), kwargs.pop("interpolation", None),
            kwargs.pop("width", None), kwargs.pop("height", None), kwargs,
            _is_array_like(volume))
    native = _scene(volume, keyword, set, spacing, origin, camera)
    try:
        x, y = (int(v) for v in pixel)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"pixel {pixel!r}: expected two whole numbers (x, y)") from None
    if not (0 <= x < 2**32 and 0 <= y < 2**32):
        raise ValueError(f"pixel ({x}, {y}): outside the image (x and y from 0)")
    return json.loads(_native.probe(native, x, y, _number("time", time)))


class Contours(list):
    """The contours of a slice: a list of (N, 2) float64 arrays (as
    ``skimage.measure.find_contours`` returns them, but in world coordinates of the plane's
    two other axes, in x, y, z order), and ``closed``: whether each is a closed loop."""

    closed = ()


def slice(volume, axis="z", at=None, isovalue=None, *, time=0.0, set=(), **kwargs):
    """The isovalue's contours on the plane ``axis = at`` (world coordinates; None: the
    middle of the box), by ``isoview slice``'s marching squares on the bilinear field, as
    :class:`Contours`. Other arguments as for :func:`render`."""
    volume = _as_input(volume)
    keyword = []
    spacing, origin = kwargs.pop("spacing", None), kwargs.pop("origin", None)
    _common(keyword, isovalue, kwargs.pop("inside", None), kwargs.pop("interpolation", None),
            None, None, kwargs, _is_array_like(volume))
    native = _scene(volume, keyword, set, spacing, origin, None)
    if at is None:
        a = "xyz".index(str(axis)) if str(axis) in ("x", "y", "z") else 0
        lo, hi = native.bounds
        at = 0.5 * (lo[a] + hi[a])
    lines = _native.slice(native, str(axis), _number("at", at), _number("time", time))
    out = Contours(points for points, _ in lines)
    out.closed = tuple(closed for _, closed in lines)
    return out


def stats(volume, *, bins=24, time=0.0, set=(), **kwargs):
    """What the field holds, as ``isoview stats`` prints it (a dict): dims, dtype (numpy's
    spelling for an array or a .npy file), spacing,
    box, count, non_finite, min, max, mean, sigma, percentiles [(p, value)], histogram
    (``bins`` counts over [min, max]) and the scene's isovalue."""
    volume = _as_input(volume)
    keyword = []
    spacing, origin = kwargs.pop("spacing", None), kwargs.pop("origin", None)
    _common(keyword, kwargs.pop("isovalue", None), None, None, None, None, kwargs, False)
    native = _scene(volume, keyword, set, spacing, origin, None)
    figures = _native.stats(native, _whole("bins", bins), _number("time", time))
    if not isinstance(volume, (Scene, str, os.PathLike)):
        figures["dtype"] = np.asarray(volume).dtype.str  # the array's, as a .npy file's
    return figures


CompareReport = collections.namedtuple("CompareReport", "passed status report notes")
CompareReport.__doc__ = """What ``isoview compare`` found: ``passed`` (exit status 0),
``status`` (0 pass, 1 a difference over the thresholds), ``report`` (its table and verdict, the
text it prints) and ``notes`` (its lines on stderr)."""


def compare(a, b, **options):
    """Compares two EXRs (paths) channel by channel as ``isoview compare A B`` does; returns a
    :class:`CompareReport`. Options are the CLI's flags with underscores: ``fail=1e-4``,
    ``fail_percent=0.1``, ``shift=True``, ``channels=["R", "Z"]``, ``diff="d.exr"``, ...
    Files that cannot be read raise ``ValueError`` with the CLI's message.

        >>> image.save_exr("a.exr"); other.save_exr("b.exr")
        >>> isoview.compare("a.exr", "b.exr", fail=1e-3).passed
        True
    """
    args = [os.fspath(a), os.fspath(b)]
    for k, v in options.items():
        flag = "--" + k.replace("_", "-")
        if v is True:
            args.append(flag)
        elif v is False or v is None:
            continue
        elif isinstance(v, (list, tuple)):
            args += [flag, ",".join(str(x) for x in v)]
        else:
            args += [flag, os.fspath(v) if isinstance(v, os.PathLike) else str(v)]
    status, report, notes = _native.compare(args)
    if status >= 2:
        line = notes.strip().splitlines()[-1] if notes.strip() else f"exit status {status}"
        raise ValueError(line[len("isoview: "):] if line.startswith("isoview: ") else line)
    return CompareReport(status == 0, status, report, notes)
