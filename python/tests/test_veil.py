"""The veil Python module against the veil executable and against independent numbers.

Run by ctest (Python.pytest) with PYTHONPATH=build/python and VEIL_EXE=build/veil, from the
repository root. Results must equal the executable's for the same words and seed: trace,
render and info run the command's own steps as values, the other commands its command line
in-process.
"""

import json
import math
import os
import subprocess

import numpy as np
import pytest

import veil

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
VEIL_EXE = os.environ.get("VEIL_EXE", os.path.join(ROOT, "build", "veil"))
SUN = os.path.join(ROOT, "examples", "scenes", "longfocus_360mm_sun.toml")
DOUBLE_GAUSS = os.path.join(ROOT, "examples", "lenses", "double_gauss_50mm.toml")
SINGLET = os.path.join(ROOT, "examples", "lenses", "singlet.toml")
PAINTED = os.path.join(ROOT, "examples", "scenes", "double_gauss_50mm_painted.toml")
MOUNT_KEY = "properties.black_anodized.scatter.reflectance"
FLOAT = 2.0 ** -23  # relative rounding of the floats an EXR stores, with a margin


def cli(*words):
    """The executable's --json report."""
    out = subprocess.run([VEIL_EXE, *map(str, words), "--json", "--quiet"], check=True,
                         capture_output=True, text=True, cwd=ROOT)
    return json.loads(out.stdout)


def without_timing(report):
    """A report without its wall times, file paths and memory estimate (which differ run to
    run: the estimate counts what the process holds)."""
    if isinstance(report, dict):
        return {k: without_timing(v) for k, v in report.items()
                if "second" not in k and k not in ("files", "scene", "memory_estimate_bytes")}
    if isinstance(report, list):
        return [without_timing(v) for v in report]
    return report


def test_trace_equals_the_executable(tmp_path):
    scene = veil.Scene(SUN)
    result = scene.trace(rays="3k", seed=7, where=["scatter(L*.edge)"])
    report = cli("trace", SUN, "-n", "3k", "--seed", "7", "--where", "scatter(L*.edge)",
                 "-o", tmp_path / "cli")
    assert without_timing(result.report) == without_timing(report)
    # The images as numpy arrays from memory: the executable's EXR pixels up to the file's
    # float rounding (2^-24 relative), layer by layer.
    mine = result.images["sensor_image"]
    theirs = veil.read_exr(tmp_path / "cli" / "sensor_image.exr")
    assert set(mine.layers) == {"all", "where1", "rest"}
    assert result.files == []  # no output folder: nothing written
    for name, layer in mine.layers.items():
        assert layer.flux.any()
        np.testing.assert_allclose(layer.flux, theirs.layer(name).flux, rtol=FLOAT, atol=0)
        np.testing.assert_allclose(layer.irradiance, theirs.layer(name).irradiance,
                                   rtol=FLOAT, atol=0)
        np.testing.assert_array_equal(layer.count, theirs.layer(name).count)
        assert layer.total_flux == theirs.layer(name).total_flux
    whole = mine.layer()
    assert whole.flux.shape == (mine.height, mine.width) == (256, 256)
    assert whole.units["irradiance"] == "W/mm^2"
    # The pixel fluxes add up to the detector's flux in the report (float storage).
    flux = report["detectors"][0]["flux"]
    assert whole.flux.sum() == pytest.approx(flux, rel=1e-6)
    # Irradiance is flux over the pixel area.
    area = mine.pixel_size_mm[0] * mine.pixel_size_mm[1]
    np.testing.assert_allclose(whole.irradiance * area, whole.flux, rtol=1e-6, atol=1e-30)


def test_an_edit_is_the_executables_set_and_leaves_the_file_alone(tmp_path):
    before = open(SUN).read()
    scene = veil.Scene(SUN).set(MOUNT_KEY, 0.2)
    edited = scene.trace(rays="2k", seed=3)
    report = cli("trace", SUN, "-n", "2k", "--seed", "3", "--set", MOUNT_KEY + "=0.2",
                 "-o", tmp_path / "cli")
    assert without_timing(edited.report) == without_timing(report)
    assert open(SUN).read() == before
    # Same rays, brighter mounts: more light scattered onto the sensor, never less.
    plain = veil.Scene(SUN).trace(rays="2k", seed=3)
    assert edited.report["detectors"][0]["flux"] > plain.report["detectors"][0]["flux"]
    # Undoing the edit gives the plain scene back.
    scene.unset(MOUNT_KEY)
    assert without_timing(scene.trace(rays="2k", seed=3).report) == \
        without_timing(plain.report)


def test_a_mechanical_edit_rebuilds_the_mounts(tmp_path):
    """Wider retainers (a mechanical dimension): the executable's --set, and other stray light
    than the design's."""
    key = "mechanics.retainers.width_mm"
    wide = veil.Scene(SUN).set(key, 4.0)
    edited = wide.trace(rays="2k", seed=5)
    report = cli("trace", SUN, "-n", "2k", "--seed", "5", "--set", key + "=4.0",
                 "-o", tmp_path / "cli")
    assert without_timing(edited.report) == without_timing(report)
    plain = veil.Scene(SUN).trace(rays="2k", seed=5)
    assert edited.report["budget"] != plain.report["budget"]
    with pytest.raises(veil.ParseError, match="width_mm"):
        veil.Scene(SUN).set(key, "wide").trace(rays=10)


def test_ghost_table_equals_the_executable(tmp_path):
    result = veil.Scene(DOUBLE_GAUSS).ghosts(rays=0, top=0)
    report = cli("ghosts", DOUBLE_GAUSS, "-n", "0", "--top", "0", "-o", tmp_path / "cli")
    assert without_timing(result.report) == without_timing(report)
    ghosts = result.report["ghosts"]
    assert len(ghosts) >= 20
    assert ghosts[0]["rank"] == 1


def test_render_components_add_up_and_equal_the_executable(tmp_path):
    options = dict(passes=2, photons="5k", rays_per_pixel=2, time_limit="none", seed=2)
    result = veil.Scene(SUN).render(**options)
    report = cli("render", SUN, "--passes", "2", "--photons", "5k", "--rays-per-pixel", "2",
                 "--time-limit", "none", "--seed", "2", "-o", tmp_path / "cli")
    assert without_timing(result.report) == without_timing(report)
    image = result.images["sensor_image"]
    total = image.layer("total").flux
    parts = sum(image.layer(c).flux for c in ("visible", "direct", "caustic", "secondary"))
    lit = total > 0
    np.testing.assert_allclose(parts[lit], total[lit], rtol=1e-5)
    theirs = veil.read_exr(tmp_path / "cli" / "sensor_image.exr")
    np.testing.assert_allclose(total, theirs.layer("total").flux, rtol=FLOAT, atol=0)


def test_a_render_run_reports_its_passes_and_writes_only_into_output(tmp_path):
    """A RenderRun's progress events (its set-up as a phase of its own, then the passes from the
    first one's start, one event per pass), its scene built once for two runs, and its files and
    checkpoint in the output folder, from which a resumed run goes on."""
    scene = veil.Scene(SUN)
    events = []
    options = dict(photons="2k", rays_per_pixel=1, time_limit="none", seed=4)
    first = scene.render(passes=2, output=tmp_path / "r", progress=events.append, **options)
    assert events[0]["task"].startswith("render: preparing") and events[0]["unit"] == ""
    passes = events[1:]
    assert [e["done"] for e in passes] == [0, 1, 2]
    assert all(e["task"] == "render" and e["unit"] == "passes" for e in passes)
    built = scene._prepared()
    assert (tmp_path / "r" / "render.checkpoint").exists()
    assert (tmp_path / "r" / "sensor_image.exr").exists()
    assert first.report["passes"] == 2
    more = scene.render(passes=3, resume=tmp_path / "r", **options)
    assert scene._prepared() is built
    assert more.report["passes"] == 3
    # Resumed to 3 passes: the same images as 3 passes at once.
    once = veil.Scene(SUN).render(passes=3, **options)
    np.testing.assert_array_equal(more.images["sensor_image"].layer("total").flux,
                                  once.images["sensor_image"].layer("total").flux)


def test_sweep_equals_the_executable(tmp_path):
    vary = MOUNT_KEY + "=0.01,0.1"
    result = veil.Scene(SUN).sweep(vary, rays=1000, batches=4)
    report = cli("sweep", SUN, "--vary", vary, "-n", "1000", "--batches", "4",
                 "-o", tmp_path / "cli")
    assert without_timing(result.report) == without_timing(report)


def test_real_rays_focus_where_the_paraxial_data_say():
    """A ray 1 um off axis, parallel to it, crosses the axis at the paraxial focus: the real
    trace (Snell's law surface by surface) against the paraxial first-order data."""
    lens = veil.Lens(SINGLET)
    first = lens.first_order()
    h = 1e-3
    origins = np.array([[0.0, h, -10.0]])
    directions = np.array([[0.0, 0.0, 1.0]])
    last = lens.image_surface - 1  # the lens's back face
    out = lens.trace(origins, directions, last_surface=last)
    assert veil.RAY_STATUS[out["status"][0]] == "ok"
    (x, y, z), (dx, dy, dz) = out["position"][0], out["direction"][0]
    efl = -h / (dy / dz)
    assert efl == pytest.approx(first["efl_mm"], rel=1e-5)
    to_axis = -y / (dy / dz)  # z distance from where the ray leaves the lens to the axis
    # The crossing, measured from the back face's vertex, is the BFL.
    vertex_z = lens.trace(np.array([[0.0, 0.0, -10.0]]), directions,
                          last_surface=last)["position"][0][2]
    assert (z + to_axis) - vertex_z == pytest.approx(first["bfl_mm"], rel=1e-5)


def test_rays_outside_the_aperture_are_clipped_and_paths_recorded():
    lens = veil.Lens(SINGLET)
    origins = np.array([[0.0, 5.0, -5.0], [0.0, 30.0, -5.0], [0.0, 0.0, -5.0]])
    directions = np.tile([0.0, 0.0, 1.0], (3, 1))
    out = lens.trace(origins, directions, record_path=True)
    names = [veil.RAY_STATUS[s] for s in out["status"]]
    assert names[0] == "ok" and names[2] == "ok"
    assert names[1].startswith("clipped")
    path = out["path"]
    assert path.shape == (3, lens.image_surface, 3)
    assert np.isnan(path[1, -1]).all()  # the clipped ray never reached the image
    assert np.isnan(out["optical_path"][1])
    # The chief ray along the axis stays on it.
    np.testing.assert_allclose(path[2, :, :2], 0.0, atol=1e-12)
    # Aimed rays: the chief ray of a 3.5 degree field leaves at 3.5 degrees.
    aimed = lens.aim(0.0, 3.5, np.array([0.0]), np.array([0.0]))
    d = aimed["directions"][0]
    assert math.degrees(math.atan2(d[1], d[2])) == pytest.approx(3.5, abs=1e-9)


def test_errors_carry_the_place(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text('[system]\nname = "x"\nwavelengths_nm = [587.6\n')
    with pytest.raises(veil.ParseError, match=r"broken\.toml:3:"):
        veil.Scene(broken).info()
    with pytest.raises(veil.ParseError, match="no 'nothing' in"):
        veil.Scene(SUN).set("properties.nothing.reflectance", 0.1).trace(rays=10)
    with pytest.raises(veil.UsageError, match="--rays"):
        veil.Scene(SUN).trace(rays=-1)
    with pytest.raises(veil.UsageError):
        veil.Scene(SUN).trace(rays=10, no_such_option=1)
    # A lens element of negative thickness cannot be built: the error names the object.
    with pytest.raises(veil.VeilError):
        veil.Scene(DOUBLE_GAUSS).set("system.surfaces[2].thickness_mm", -5).trace(rays=10)
    with pytest.raises(ValueError, match="same shape"):
        veil.Lens(SINGLET).trace(np.zeros((2, 3)), np.zeros((3, 3)))


def test_view_writes_one_page(tmp_path):
    page = tmp_path / "scene.html"
    result = veil.Scene(SUN).view(page, where="fresnel{2} and hit(sensor)", first=5)
    assert page.exists()
    assert result.report["paths_drawn"] >= 5
    assert result.report["objects"] == 43  # 42 scene objects and the detector's grid


def test_scatter_reports_library_materials_and_follows_edits():
    """The bundled paint is 5 % Lambertian; with the mounts edited to the library's 2 % flat
    black, that is what the barrel carries."""
    scene = veil.Scene(PAINTED)
    report = scene.scatter(property=["black_polyurethane_paint"], wavelength=[550]).report
    (paint,) = report["properties"]
    assert paint["reflect_tis"][0][0] == pytest.approx(0.05, abs=1e-12)
    assert "barrel" in paint["objects"]
    flat = scene.set("mechanics.property", "flat_black_paint_2pct").scatter(wavelength=[550])
    by_name = {p["name"]: p for p in flat.report["properties"]}
    assert "black_polyurethane_paint" in by_name  # still the stop's
    assert "barrel" in by_name["flat_black_paint_2pct"]["objects"]
    assert by_name["flat_black_paint_2pct"]["reflect_tis"][3][0] == pytest.approx(0.02, abs=1e-12)


def test_glare_of_a_singlet_follows_its_coating():
    """An uncoated singlet has ghost glare; with ideal antireflection faces and black edges
    it has none at all."""
    quick = dict(field=["0,0"], passes=3, photons="5k", rays_per_pixel=16)
    bare = veil.Scene(SINGLET).glare(**quick).report["fields"][0]
    assert 0 < bare["specular"]["value"] < 0.01
    perfect = (veil.Scene(SINGLET)
               .set("system.surfaces[1].coating", "ideal_ar")
               .set("system.surfaces[2].coating", "ideal_ar"))
    report = perfect.glare(**quick).report["fields"][0]
    assert report["specular"]["value"] == 0.0


def test_a_scene_reads_its_files_once(tmp_path):
    """Scene holds the texts of its scene and lens files: a change on disk (or the files'
    removal) is not seen until reload()."""
    (tmp_path / "scenes").mkdir()
    (tmp_path / "lenses").mkdir()
    scene_file = tmp_path / "scenes" / "sun.toml"
    lens_file = tmp_path / "lenses" / "longfocus_360mm.toml"
    scene_file.write_text(open(SUN).read())
    lens_file.write_text(open(os.path.join(ROOT, "examples", "lenses",
                                           "longfocus_360mm.toml")).read())
    scene = veil.Scene(scene_file)
    first = scene.trace(rays=500, seed=4).report
    text = scene_file.read_text()
    scene_file.write_text(text.replace("reflectance = 0.05", "reflectance = 0.5"))
    lens_file.unlink()
    again = scene.trace(rays=500, seed=4).report
    assert without_timing(again) == without_timing(first)
    assert scene.lens().surface_names == veil.Lens(SUN).surface_names
    with pytest.raises(veil.VeilError, match="longfocus_360mm.toml"):
        scene.reload().trace(rays=500, seed=4)  # the lens file is gone now
    lens_file.write_text(open(os.path.join(ROOT, "examples", "lenses",
                                           "longfocus_360mm.toml")).read())
    brighter = scene.reload().trace(rays=500, seed=4).report
    assert brighter["detectors"][0]["flux"] > first["detectors"][0]["flux"]
