"""Bad decks: one message naming the key path and YAML line, exit code 2, never a traceback."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from mpmsim.cli import app

BASE = """\
title: base
units: mm-g-ms
grid:
  cell_size: 1.0
  boundaries: {ymin: fixed}
materials:
  block: {type: neo_hookean, K: 100.0, G: 50.0, density: 0.001}
bodies:
  - {shape: rectangle, min: [0, 0], max: [4, 4], material: block}
time: {end: 0.1}
"""

# (name, text replacements on BASE (old, new) or a whole text, expected key path, expected line, words)
CASES = [
    ("yaml syntax", [("  cell_size: 1.0", "  cell_size: [1.0")], None, 5, "YAML syntax"),
    ("unknown key with hint", [("title: base", "title: base\ntitel: again")], "titel", 2, "did you mean 'title'"),
    ("key of another material type", [("K: 100.0, G: 50.0", "E: 100.0, nu: 0.3")], "materials.block.E", 7,
     "unknown key 'E' for 'neo_hookean' (its keys: G, K, density, type)"),
    ("missing required key", [("time: {end: 0.1}", "time: {cfl: 0.5}")], "time.end", 10, "required"),
    ("negative modulus", [("K: 100.0", "K: -100.0")], "materials.block.K", 7, "greater than 0"),
    ("NaN modulus", [("K: 100.0", "K: .nan")], "materials.block.K", 7, "finite number"),
    ("infinite modulus", [("K: 100.0", "K: .inf")], "materials.block.K", 7, "finite number"),
    ("clip box of the wrong dimension", [("max: [4, 4], material: block}", "max: [4, 4], material: block, "
                                          "clip: {min: [0, 0, 0], max: [1, 1, 1]}}")],
     "bodies.0.clip.min", 9, "2 components"),
    ("absurd magnitude", [("K: 100.0", "K: 1.0e300")], "materials.block.K", 7, "beyond +-1e+30"),
    ("zero cell size", [("  cell_size: 1.0", "  cell_size: 0")], "grid.cell_size", 4, "must be > 0"),
    ("wrong type", [("K: 100.0", "K: stiff")], "materials.block.K", 7, "number"),
    ("unknown material type", [("type: neo_hookean", "type: neo_hokean")], "materials.block", 7, "neo_hookean"),
    ("unknown shape", [("shape: rectangle", "shape: rectangel")], "bodies.0", 9, "rectangle"),
    ("undefined material", [("material: block}", "material: stone}")], "bodies.0.material", 9, "no material named 'stone'"),
    ("vector length", [("min: [0, 0], max: [4, 4]", "min: [0, 0, 0], max: [4, 4, 4]")], "bodies.0.min", 9, "2 components"),
    ("extrude_axis in 2D", [("max: [4, 4], material: block}", "max: [4, 4], material: block, extrude_axis: y}")],
     "bodies.0.extrude_axis", 9, "3d deck's particle body"),
    ("3D shape in 2D", [("shape: rectangle, min: [0, 0], max: [4, 4]", "shape: sphere, center: [0, 0, 0], radius: 1")],
     "bodies.0.shape", 9, "3D shape"),
    ("axisymmetric with CPDI", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric\nshape_function: cpdi")], "shape_function", 4,
     "axisymmetric analysis takes shape_function linear or gimp"),
    ("axisymmetric body across the axis", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric"), ("min: [0, 0]", "min: [-1, 0]")], "bodies.0", 10,
     "reaches r = -1 < 0"),
    ("axisymmetric thickness", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric\nthickness: 2.0")], "thickness", 4, "per radian"),
    ("axisymmetric radial gravity", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric\ngravity: [-9.81, 0.0]")], "gravity.0", 4,
     "breaks the axial symmetry"),
    ("axisymmetric domain at r < 0", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric"), ("  cell_size: 1.0", "  cell_size: 1.0\n"
                                      "  domain: {min: [-1, 0], max: [5, 5]}")], "grid.domain.min.0", 6, "r >= 0"),
    ("axisymmetric pressure off the axis", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric"),
                                            ("time: {end: 0.1}", "time: {end: 0.1}\nloads:\n  - {region: {min: [0, 0], "
                                             "max: [4, 4]}, pressure: 1.0, center: [1.0, 0.0]}")],
     "loads.0.center.0", 13, "center r must be 0"),
    ("pressure without a centre", [("time: {end: 0.1}", "time: {end: 0.1}\nloads:\n  - {region: {min: [0, 0], "
                                    "max: [4, 4]}, pressure: 1.0}")], "loads.0", 12, "needs both pressure and center"),
    ("axisymmetric implicit", [("units: mm-g-ms", "units: mm-g-ms\nanalysis: axisymmetric\nintegrator: implicit\nupdate: {scheme: pic}"),
                               ("time: {end: 0.1}", "time: {end: 0.1, dt: 0.01}")], "integrator", 4, "explicit MPM"),
    ("bad enum", [("{ymin: fixed}", "{ymin: glued}")], "grid.boundaries.ymin", 5, "'fixed'"),
    ("both cfl and dt", [("time: {end: 0.1}", "time: {end: 0.1, cfl: 0.5, dt: 0.001}")], "time.dt", 10, "either"),
    ("energy ledger off the explicit step", [("time: {end: 0.1}", "time: {end: 0.1, dt: 0.01}\n"
                                               "integrator: implicit\nupdate: {scheme: pic}\n"
                                               "output: {energy_ledger: true}")],
     "output.energy_ledger", 13, "explicit MPM step"),
    ("implausible density", [("density: 0.001", "density: 2.78")], "materials.block.density", 7, "g/mm^3"),
    ("density next to nothing", [("density: 0.001", "density: 1.0e-300")], "materials.block.density", 7,
     "density 1e-300 is implausible in mm-g-ms units"),
    ("SI with mm-g-ms numbers", [("units: mm-g-ms", "units: SI")], "materials.block.density", 7,
     "density 0.001 is implausible in SI units: density is in kg/m^3"),
    ("moduli in Pa in an mm-g-ms deck", [("K: 100.0, G: 50.0", "K: 1.0e11, G: 5.0e10")], "materials.block", 7,
     "wave speed sqrt(modulus / density) = 1.29e+07 m/s is faster than any solid's (diamond: 1.8e4 m/s): moduli "
     "are in MPa in mm-g-ms units (E in Pa gives 1e6 times too stiff)"),
    ("missing image", [("  - {shape: rectangle, min: [0, 0], max: [4, 4], material: block}",
                        "  - {shape: image, file: nowhere.png, pixel_size: 0.5, origin: [0, 0],\n"
                        "     map: [{grey: [0, 10], material: block}]}")], "bodies.0.file", 9, "not found"),
    ("rigid table", [("materials:\n", "materials:\n  platen: {type: rigid, velocity: {times: [0, 1, 1], values: [[0, 0], [0, 1], [0, 2]]}}\n")],
     "materials.platen.velocity.times", 7, "strictly increasing"),
    ("duplicate key", [("time: {end: 0.1}", "time: {end: 0.1}\ntime: {end: 0.2}")], "time", 11, "duplicate"),
    ("domain misses body", [("  cell_size: 1.0", "  cell_size: 1.0\n  domain: {min: [0, 0], max: [2, 2]}")],
     "bodies.0", 10, "extends outside grid.domain: 2 beyond its xmax = 2, 2 beyond its ymax = 2"),
    ("empty deck", "", None, 1, "empty"),
    ("negative Mie-Gruneisen K", [("type: neo_hookean, K: 100.0, G: 50.0,", "type: mie_gruneisen, K: -1.0, gamma0: 2, S1: 1.4,")],
     "materials.block.K", 7, "greater than 0"),
    ("artificial viscosity on unknown material", [("time: {end: 0.1}", "time: {end: 0.1}\nartificial_viscosity: {A1: 0.4, A2: 4, materials: [steel]}")],
     "artificial_viscosity.materials.0", 11, "no material named 'steel' (materials: block)"),
    ("negative artificial viscosity", [("time: {end: 0.1}", "time: {end: 0.1}\nartificial_viscosity: {A1: -0.4, A2: 4}")],
     "artificial_viscosity.A1", 11, "greater than or equal to 0"),
    ("constrained faces need whole cells", [("{ymin: fixed}", "{xmin: fixed, xmax: roller}"),
                                           ("max: [4, 4]", "max: [4.5, 4]")], "grid.cell_size", 4, "whole number"),
    ("contact pair names no material", [("time: {end: 0.1}\n", "time: {end: 0.1}\ncontact: {pairs: [{between: [block, stone], law: stick}]}\n")],
     "contact.pairs.0.between.1", 11, "no material named 'stone'"),
    ("contact pair misspells a material", [("time: {end: 0.1}\n", "time: {end: 0.1}\ncontact: {pairs: [{between: [blok, block], law: stick}]}\n")],
     "contact.pairs.0.between.0", 11, "no material named 'blok' (did you mean 'block'?)"),
    ("unknown normal method", [("time: {end: 0.1}\n", "time: {end: 0.1}\ncontact: {normal: logistic}\n")],
     "contact.normal", 11, "'logistic_regression'"),
    ("bad interface stiffness", [("time: {end: 0.1}\n", "time: {end: 0.1}\ncontact: {default: {law: interface, Dt: -2}}\n")],
     "contact.default.Dt", 11, "'perfect'"),
    ("load with face and normal", [("time: {end: 0.1}\n", "time: {end: 0.1}\nloads: [{region: {min: [0, 3], max: [4, 4]}, "
                                    "face: ymax, normal: [0, 1], traction: [0, 1]}]\n")], "loads.0", 11, "either face or normal"),
    ("load region misses the body", [("time: {end: 0.1}\n", "time: {end: 0.1}\nloads: [{region: {min: [10, 10], max: [11, 11]}, "
                                      "face: ymax, traction: [0, 1]}]\n")], "loads.0.region", 11, "no particle"),
    ("transversely isotropic without energy", [("type: neo_hookean, K: 100.0, G: 50.0,",
                                                "type: transversely_isotropic, EA: 100, ET: 10, GA: 5, nuA: 3.0, nuT: 0.3, "
                                                "axis: [0, 1],")], "materials.block.nuA", 7, "positive strain energy"),
    ("specified normal without vector", [("time: {end: 0.1}\n", "time: {end: 0.1}\ncontact: {normal: specified}\n")],
     "contact.normal_vector", 11, "needs normal_vector"),
    ("static friction below kinetic", [("time: {end: 0.1}\n", "time: {end: 0.1}\ncontact: {default: "
                                        "{law: coulomb, friction: 0.3, static_friction: 0.2}}\n")],
     "contact.default.static_friction", 11, "below the kinetic friction"),
    ("history of unknown material", [("time: {end: 0.1}\n", "time: {end: 0.1}\noutput: {material_stress: [stone]}\n")],
     "output.material_stress.0", 11, "no material named 'stone'"),
]


def _text(spec) -> str:
    if isinstance(spec, str):
        return spec
    text = BASE
    for old, new in spec:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def test_base_deck_is_valid(tmp_path):
    deck = tmp_path / "base.yaml"
    deck.write_text(BASE)
    result = CliRunner().invoke(app, ["check", str(deck)])
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("name,spec,path,line,words", CASES, ids=[c[0] for c in CASES])
def test_bad_deck_message(tmp_path, name, spec, path, line, words):
    deck = tmp_path / "bad.yaml"
    deck.write_text(_text(spec))
    result = CliRunner().invoke(app, ["check", str(deck)])
    out = result.output
    assert result.exit_code == 2, out
    assert "Traceback" not in out
    assert f"line {line}" in out, out
    if path is not None:
        assert f": {path}: " in out, out
    assert words in out, out


def test_missing_deck_file(tmp_path):
    result = CliRunner().invoke(app, ["run", str(tmp_path / "absent.yaml")])
    assert result.exit_code == 2
    assert "cannot read deck file" in result.output
    assert "Traceback" not in result.output


def test_absurd_step_or_output_counts_are_refused_with_the_estimate(tmp_path):
    """An end time of 1e12 ms at a step of a few microseconds: `run` refuses it (exit 2) with
    the estimate and the override, before writing anything; the same for 1e-300 s output
    intervals; --max-steps lets a user go on."""
    deck = tmp_path / "d.yaml"
    deck.write_text(BASE.replace("time: {end: 0.1}", "time: {end: 1.0e12}"))
    out = tmp_path / "o"
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(out), "--quiet"])
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert "time.end: about" in text and "steps" in text and "--max-steps" in text
    assert not out.exists()
    deck.write_text(BASE.replace("time: {end: 0.1}", "time: {end: 0.1}\noutput: {history_interval: 1.0e-300}"))
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(out), "--quiet"])
    assert result.exit_code == 2, result.output
    assert "output.history_interval: about 1e+299 outputs" in " ".join(result.output.split())


@pytest.mark.parametrize("content,words", [
    (b"title: caf\xe9\n", "not UTF-8"),
    (("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{c}: &{c} [" + ", ".join(f"*{p}" for _ in range(9)) + "]\n"
        for p, c in zip("abcdefgh", "bcdefghi"))).encode(), "aliases (*name) expand to"),
    (("x: " + "[" * 5000 + "]" * 5000 + "\n").encode(), "nested too deeply"),
], ids=["latin-1", "alias bomb", "deep nesting"])
def test_unreadable_decks_are_one_line_errors(tmp_path, content, words):
    deck = tmp_path / "bad.yaml"
    deck.write_bytes(content)
    for command in ("check", "run"):
        result = CliRunner().invoke(app, [command, str(deck)])
        assert result.exit_code == 2, result.output
        assert words in result.output and "Traceback" not in result.output


def test_a_deck_given_as_a_mapping_is_named_by_key_path_without_a_file():
    """Simulation.from_deck(mapping): the message names the deck and the key, not the file or
    line of a YAML dump the caller never saw; scene-level problems (the body outside the domain,
    with side and distance) the same way."""
    import yaml

    from mpmsim import DeckError, Simulation

    data = yaml.safe_load(BASE)
    data["materials"]["block"]["K"] = -1.0
    with pytest.raises(DeckError) as exc:
        Simulation.from_deck(data, name="mine")
    assert str(exc.value) == "deck 'mine' (a mapping): materials.block.K: input should be greater than 0"
    data = yaml.safe_load(BASE)
    data["grid"]["domain"] = {"min": [0, 0], "max": [2, 2]}
    with pytest.raises(DeckError) as exc:
        Simulation.from_deck(data)
    assert str(exc.value).startswith("deck 'deck' (a mapping): bodies.0: the body extends outside grid.domain: "
                                     "2 beyond its xmax = 2, 2 beyond its ymax = 2")
    assert ".yaml" not in str(exc.value) and "line" not in str(exc.value)
