"""veil from Python: the same commands as the ``veil`` executable, in-process.

    import veil
    scene = veil.Scene("examples/scenes/longfocus_360mm_sun.toml")
    result = scene.trace(rays="20k", where=["scatter(L*.edge)"], seed=1)
    result.report["detectors"][0]["flux"]          # W, as `veil trace --json` reports it
    result.images["sensor_image"].layer("total").irradiance   # numpy (rows, columns), W/mm^2

    scene.set("properties.black_anodized.scatter.reflectance", 0.02)   # what if...
    darker = scene.trace(rays="20k", seed=1)      # same rays, edited scene

Every command method takes the command's options as keyword arguments, spelled as on the
command line with ``_`` for ``-`` (``min_flux=1e-5`` is ``--min-flux 1e-5``, ``where=[...]``
repeats ``--where``, ``True`` gives a flag): the words are parsed by the command line's own
definitions, so the options, their defaults, their checks and the results are the
executable's (docs/cli.md, docs/python.md).

``trace``, ``render`` and ``info`` run as values: the scene is built once per edit and
``field`` list and kept, the run's images come back as numpy arrays from memory, and files
are written only into ``output``; ``progress=callable`` receives each progress event as a
dict. The other commands run the command line in-process: their files go into ``output``
when given, otherwise into a temporary folder that is read (reports, EXR images) and removed.

Errors raise :class:`VeilError`: :class:`ParseError` (the message names file:line:col),
:class:`ModelError` (the object), :class:`UsageError` (an option veil does not take).
"""

import json
import os
import shutil
import sys
import tempfile

from . import _veil
from ._veil import ModelError, ParseError, UsageError, VeilError

__all__ = ["Scene", "Lens", "Result", "Image", "Layer", "run", "read_exr", "VeilError",
           "ParseError", "ModelError", "UsageError", "RAY_STATUS"]

#: Lens.trace status codes: RAY_STATUS[code] names one ("ok", "missed surface", ...).
RAY_STATUS = list(_veil.RAY_STATUS)


def _toml_value(value):
    """A Python value as the value text of a --set or --vary edit."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return str(value)


def _words(options):
    """Keyword options as command-line words, in the order given."""
    words = []
    for name, value in options.items():
        if value is None or value is False:
            continue
        flag = "-o" if name == "output" else "--" + name.replace("_", "-")
        if value is True:
            words.append(flag)
        elif isinstance(value, (list, tuple)):
            for v in value:
                words += [flag, _toml_value(v) if not isinstance(v, str) else v]
        else:
            words += [flag, _toml_value(value)]
    return words


def run(*words, snapshots=None):
    """Runs ``veil WORDS...`` in-process, as the shell would, and returns a :class:`Result`.

    ``run("trace", "scene.toml", "-n", "20k", "--json")``. With ``--json`` the report is
    parsed into ``Result.report``; without it ``Result.text`` holds what the command printed.
    Progress is off (``--quiet`` is added); notes, warnings and errors go to ``sys.stderr``
    once the command returns.
    """
    words = [str(w) for w in words]
    if "--quiet" not in words and words and not words[0].startswith("-"):
        words.append("--quiet")
    r = _veil.run(words, snapshots or {})
    if r.stderr:
        sys.stderr.write(r.stderr)
    report = None
    if "--json" in words and r.stdout.strip():
        report = json.loads(r.stdout)
    return Result(report=report, text=r.stdout, exit_code=r.exit_code)


def read_exr(path):
    """A detector EXR written by veil as an :class:`Image`."""
    return Image(_veil.read_exr(str(path)))


class Layer:
    """One layer of a detector image: numpy arrays (rows, columns), row 0 at the top (+y),
    column 0 at the left (-x), as the EXR stores them (docs/cli.md)."""

    def __init__(self, name, d, units):
        self.name = name
        self.flux = d["flux"]                  #: per pixel, flux_unit
        self.irradiance = d["irradiance"]      #: flux_unit / mm^2
        self.variance = d["variance"]          #: of the pixel flux, flux_unit^2
        self.count = d["count"]                #: rays per pixel
        self.total_flux = d["total_flux"]
        self.total_relative_error = d["total_relative_error"]
        self.units = units

    def __repr__(self):
        return "Layer(%r, %s pixels, total %.6g %s)" % (
            self.name, "x".join(map(str, self.flux.shape[::-1])), self.total_flux,
            self.units["flux"])


class Image:
    """A detector's image: its layers (``total``, per criterion, per render component)."""

    def __init__(self, d):
        self.detector = d["detector"]
        self.width, self.height = d["width"], d["height"]
        self.detector_size_mm = d["detector_size_mm"]
        self.pixel_size_mm = d["pixel_size_mm"]
        self.emitted_rays = d["emitted_rays"]
        self.units = {"flux": d["flux_unit"], "irradiance": d["irradiance_unit"],
                      "variance": d["variance_unit"], "count": d["count_unit"]}
        # A trace without criteria writes one unnamed layer: it is the total.
        self.layers = {name or "total": Layer(name or "total", layer, self.units)
                       for name, layer in d["layers"].items()}

    def layer(self, name=None):
        """A layer by name; without one, the whole image (``total``, or ``all`` beside the
        criterion layers of a trace with ``where``)."""
        if name is None:
            name = "total" if "total" in self.layers else "all"
        if name not in self.layers:
            raise KeyError("%s has no layer %r; it has %s" % (
                self.detector, name, ", ".join(self.layers)))
        return self.layers[name]

    def __repr__(self):
        return "Image(%r, %dx%d pixels, layers %s)" % (
            self.detector, self.width, self.height, ", ".join(self.layers))


class Result:
    """What a command returned: its JSON report (a dict, as ``--json`` prints it), the
    detector images it wrote (by detector name), and the files it left (when ``output``
    was given)."""

    def __init__(self, report=None, images=None, files=None, text="", exit_code=0):
        self.report = report
        self.images = images or {}
        self.files = files or []
        self.text = text
        self.exit_code = exit_code

    def __getitem__(self, key):
        return self.report[key]

    def __repr__(self):
        keys = ", ".join(sorted(self.report)) if isinstance(self.report, dict) else ""
        return "Result(report keys: %s; images: %s)" % (keys, ", ".join(self.images) or "none")


class Scene:
    """A scene (or lens) file and edits to it.

    The scene file (and the lens file it names) is read once, here: every command runs on
    that text, so a file changed on disk afterwards is not seen until ``reload()``.
    ``set(key, value)`` records an edit (a TOML path as ``veil sweep --vary`` names it); every
    command then runs on the edited scene, as ``veil --set KEY=VALUE COMMAND ...`` would, and
    the file on disk is left alone. ``glass_catalogs``: extra AGF files (``--glass-catalog``).
    """

    def __init__(self, path, glass_catalogs=()):
        self.path = os.fspath(path)
        self.glass_catalogs = [os.fspath(c) for c in glass_catalogs]
        self.edits = {}
        self._built, self._built_key = None, None
        self.reload()

    def reload(self):
        """Reads the scene and lens files again (the edits stay). Returns the scene."""
        self._snapshots = _veil.snapshot(self.path)
        self._built, self._built_key = None, None
        return self

    def _prepared(self, fields=()):
        """The scene built for tracing with the current edits and these --field beams; kept
        until the edits, the fields or the files change."""
        key = (tuple(self.edits.items()), tuple(fields))
        if self._built_key != key:
            self._built = None  # the old scene's memory first
            self._built = _veil.PreparedScene(
                self.path, self.glass_catalogs,
                ["%s=%s" % (k, v) for k, v in self.edits.items()], list(fields),
                self._snapshots)
            self._built_key = key
        return self._built

    # Edits

    def set(self, key, value):
        """Edits one value (``"mechanics.barrel.wall_mm"``, ``"properties.black.scatter
        .reflectance"``); checked when the next command reads the scene. Returns the scene."""
        self.edits[key] = _toml_value(value)
        return self

    def unset(self, key):
        self.edits.pop(key, None)
        return self

    def copy(self):
        other = Scene.__new__(Scene)
        other.path, other.glass_catalogs = self.path, list(self.glass_catalogs)
        other.edits, other._snapshots = dict(self.edits), self._snapshots
        other._built, other._built_key = self._built, self._built_key
        return other

    def _common(self):
        words = []
        for c in self.glass_catalogs:
            words += ["--glass-catalog", c]
        for key, value in self.edits.items():
            words += ["--set", "%s=%s" % (key, value)]
        return words

    # Commands

    def command(self, name, *arguments, output=None, keep=False, **options):
        """Runs ``veil NAME SCENE ARGUMENTS... OPTIONS...`` on this scene with ``--json``.

        Files go to ``output`` (a folder, or a file for ``export`` and ``view``); without it,
        to a temporary folder whose EXR images are read into ``Result.images`` before it is
        removed (``keep=True`` keeps it and names it in ``Result.files``).
        """
        scratch = None
        if output is None and name not in ("info", "export", "view", "rays"):
            scratch = tempfile.mkdtemp(prefix="veil_")
            output = os.path.join(scratch, name)
        words = [name, self.path] + [str(a) for a in arguments] + _words(options)
        if output is not None:
            words += ["-o", os.fspath(output)]
        words += self._common() + ["--json"]
        try:
            result = run(*words, snapshots=self._snapshots)
            files = (result.report or {}).get("files", []) if isinstance(result.report, dict) else []
            result.images = {}
            for f in files:
                if str(f).endswith(".exr"):
                    image = read_exr(f)
                    result.images[image.detector] = image
            result.files = [] if scratch and not keep else list(files)
            return result
        finally:
            if scratch and not keep:
                shutil.rmtree(scratch, ignore_errors=True)

    def _value(self, function, name, output, progress, options):
        """A command run as values (trace, render): its report, text, images and files."""
        words = [name, self.path] + _words(options)
        if output is not None:
            words += ["-o", os.fspath(output)]
        r = function(words, self._prepared, progress)
        return Result(report=r["report"], text=r["text"], files=list(r["files"]),
                      images={d: Image(image) for d, image in r["images"].items()})

    def info(self, **options):
        """First-order data, surfaces, spots and import report (``veil info --json``)."""
        words = ["info", self.path] + _words(options) + self._common()
        return _veil.info(words, self._snapshots)

    def trace(self, rays, output=None, progress=None, **options):
        """Forward Monte Carlo (``veil trace``): ``rays`` per source (20000, "20k", "2M").
        Files only into ``output``; ``progress``: a callable given each progress event."""
        return self._value(_veil.trace, "trace", output, progress, dict(rays=rays, **options))

    def paths(self, where, **options):
        """The first rays with a path matching ``where`` (``veil paths``)."""
        return self.command("paths", where=where, **options)

    def ghosts(self, **options):
        """Every two-reflection ghost ranked (``veil ghosts``): ``report["ghosts"]``."""
        return self.command("ghosts", **options)

    def render(self, output=None, progress=None, **options):
        """Bidirectional photon mapping (``veil render``): images with their components.
        Files and the checkpoint only into ``output`` (or ``resume``); ``progress``: a
        callable given each pass's event."""
        return self._value(_veil.render, "render", output, progress, options)

    def sweep(self, vary, **options):
        """A what-if study (``veil sweep``): ``vary`` is one ``KEY=VALUES`` or a list."""
        if isinstance(vary, str):
            vary = [vary]
        return self.command("sweep", vary=list(vary), **options)

    def pst(self, angles, **options):
        """Point source transmittance against the off-axis angle (``veil pst``)."""
        return self.command("pst", angles=angles, **options)

    def objects(self, **options):
        """The parts the sources light and the detector sees, ranked (``veil objects``)."""
        return self.command("objects", **options)

    def glare(self, **options):
        """Veiling glare index (ISO 9358) per position: ghosts and scatter (``veil glare``)."""
        return self.command("glare", **options)

    def scatter(self, **options):
        """The scatter models: TIS against incidence, BRDF plots (``veil scatter``)."""
        return self.command("scatter", **options)

    def view(self, output, **options):
        """The scene (and with ``where`` its ray paths) as a 3D HTML page (``veil view``)."""
        return self.command("view", output=output, **options)

    def lens(self):
        """The scene's lens, read with the current edits, for real-ray traces."""
        lens = Lens.__new__(Lens)
        lens._init(self.path, self.glass_catalogs, self.edits, self._snapshots)
        return lens

    def __repr__(self):
        return "Scene(%r%s)" % (self.path, ", edits %r" % self.edits if self.edits else "")


class Lens:
    """A lens (a lens file, or a scene's lens) for real-ray traces in numpy.

    ``trace(origins, directions)`` traces (N, 3) arrays of rays (global frame, mm; surface
    1's vertex at z = 0) through the surfaces and returns arrays: ``status`` (RAY_STATUS
    codes), ``surface`` (where each ray stopped), ``position`` and ``direction`` there,
    ``optical_path`` (mm, NaN unless ok) and with ``record_path=True`` ``path`` (N, surfaces,
    3; NaN past where a ray stopped). ``aim(fx, fy, px, py)`` gives the rays from a field
    point through pupil points, aimed as ``veil info`` aims its spots.
    """

    def __init__(self, path, glass_catalogs=(), edits=None):
        path = os.fspath(path)
        self._init(path, glass_catalogs, edits, _veil.snapshot(path))

    def _init(self, path, glass_catalogs, edits, snapshots):
        self.path = path
        self.glass_catalogs = [os.fspath(c) for c in glass_catalogs]
        self.edits = dict(edits or {})
        self._snapshots = snapshots
        self._lens = _veil.Lens(self.path, self.glass_catalogs,
                                [(k, _toml_value(v)) for k, v in self.edits.items()], snapshots)

    name = property(lambda self: self._lens.name)
    wavelengths_nm = property(lambda self: self._lens.wavelengths_nm)
    primary_wavelength = property(lambda self: self._lens.primary_wavelength)
    surface_names = property(lambda self: self._lens.surface_names)
    stop_surface = property(lambda self: self._lens.stop_surface)
    image_surface = property(lambda self: self._lens.image_surface)

    def first_order(self):
        """First-order data at every wavelength, as ``veil info --json`` reports it."""
        scene = Scene.__new__(Scene)
        scene.path, scene.glass_catalogs = self.path, self.glass_catalogs
        scene.edits = {k: _toml_value(v) for k, v in self.edits.items()}
        scene._snapshots = self._snapshots
        return scene.info()

    def trace(self, origins, directions, wavelength=None, first_surface=1, last_surface=-1,
              clip=True, record_path=False):
        return self._lens.trace(origins, directions, wavelength, first_surface, last_surface,
                                clip, record_path)

    def aim(self, field_x, field_y, px, py, wavelength=None, mode="real"):
        return self._lens.aim(field_x, field_y, px, py, wavelength, mode)

    def __repr__(self):
        return "Lens(%r: %s)" % (self.path, self.name)
