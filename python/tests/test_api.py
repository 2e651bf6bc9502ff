"""The package against the CLI and against exact facts: arrays, files, errors, exports."""

import json
import math
import pickle
import subprocess

import numpy as np
import pytest

import densepack


def cli_packing(cli, scene_path, out, *args):
    subprocess.run([cli, "run", str(scene_path), "--out", str(out), "--quiet", *args], check=True)
    return json.loads(out.read_text())


def test_walls8_arrays_are_the_cli_packing_bit_for_bit(cli, scenes, tmp_path):
    scene = densepack.Scene.from_toml(scenes / "walls_8_spheres.toml").with_seed(5)
    packing = densepack.run(scene, progress=False)
    assert len(packing) == 8
    for name, shape, dtype in [
        ("centers", (8, 3), np.float64),
        ("radii", (8,), np.float64),
        ("semi_axes", (8, 3), np.float64),
        ("orientations", (8, 4), np.float64),
        ("half_axes", (8, 3), np.float64),
    ]:
        a = getattr(packing, name)
        assert a.shape == shape and a.dtype == dtype, name
    assert list(packing.kinds) == ["sphere"] * 8
    assert np.isnan(packing.half_axes).all()
    # The CLI run of the same scene and seed: the same particles, bit for bit.
    record = cli_packing(cli, scenes / "walls_8_spheres.toml", tmp_path / "cli.json", "--seed", "5")
    cli_centers = np.array([p["center"] for p in record["particles"]])
    cli_radii = np.array([p["radius"] for p in record["particles"]])
    assert np.array_equal(packing.centers, cli_centers)
    assert np.array_equal(packing.radii, cli_radii)
    assert packing.min_gap == record["min_gap"] and packing.seed == record["seed"] == 5
    # Eight spheres jam on the simple cubic lattice in the walled cube (paper 001, Fig. 5):
    # φ = π/6 exactly, radius 1/2.
    assert packing.packing_fraction == pytest.approx(math.pi / 6, rel=1e-9)
    assert np.allclose(packing.radii, 0.5, rtol=1e-9)
    # Saved by Python, the file holds the same particles as the CLI's.
    packing.save(tmp_path / "py.json")
    saved = json.loads((tmp_path / "py.json").read_text())
    assert saved["particles"] == record["particles"]
    again = densepack.Packing.load(tmp_path / "py.json")
    assert np.array_equal(again.centers, packing.centers)


def test_seeds_give_different_packings_and_pickling_round_trips(scenes):
    scene = densepack.Scene.from_toml(scenes / "sample_spheres.toml")
    a = densepack.run(scene.with_seed(1), progress=False)
    b = densepack.run(scene.with_seed(2), progress=False)
    assert not np.array_equal(a.centers, b.centers)
    assert pickle.loads(pickle.dumps(scene)) == scene
    c = pickle.loads(pickle.dumps(a))
    assert np.array_equal(c.centers, a.centers) and c.stats == a.stats


def test_scene_dict_round_trip_and_overrides_equal_edited_files(scenes):
    text = (scenes / "walls_8_spheres.toml").read_text()
    scene = densepack.Scene.from_toml(text)
    assert densepack.Scene.from_dict(scene.to_dict()) == scene
    edited = densepack.Scene.from_toml(text.replace("rate = 0.01", "rate = 0.02"))
    assert scene.with_values({"stage.0.rate": 0.02}) == edited
    edited = densepack.Scene.from_toml(text.replace('queue = "heap"', 'queue = "calendar"'))
    assert scene.with_values({"queue": "calendar"}) == edited


@pytest.mark.parametrize(
    "values, field",
    [
        ({"particles.diameter": -1.0}, "particles.diameter"),
        ({"stage.0.rate": float("nan")}, "rate"),
        ({"container.size": [2.0, 2.0]}, "container.size"),
        ({"particles.no_such_field": 1}, "no_such_field"),
        ({"stage.5.rate": 0.1}, "stage.5"),
    ],
)
def test_bad_overrides_raise_value_error_naming_the_field(scenes, values, field):
    scene = densepack.Scene.from_toml(scenes / "walls_8_spheres.toml")
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        scene.with_values(values)


def test_bad_scene_files_raise_the_files_message(scenes):
    text = (scenes / "walls_8_spheres.toml").read_text().replace("count = 8", "count = 0")
    with pytest.raises(ValueError, match=r"particles\.count"):
        densepack.Scene.from_toml(text)
    with pytest.raises(OSError, match="no_such.toml"):
        densepack.Scene.from_toml("no_such.toml")


def test_failed_run_raises_the_verdict_and_writes_nothing(scenes, tmp_path):
    # A packing fraction beyond jamming for a walled 8-sphere cube: the stage jams first.
    scene = densepack.Scene.from_toml(scenes / "walls_8_spheres.toml").with_values(
        {"stage.0.until": {"packing_fraction": 0.7}}
    )
    with pytest.raises(densepack.RunFailed) as failure:
        densepack.run(scene, progress=False)
    assert failure.value.verdict == "jammed_before_goal"
    assert failure.value.stage == 0
    assert "jammed_before_goal" in str(failure.value)


def test_voxels_and_exports_agree_with_numpy_readers(scenes, tmp_path):
    packing = densepack.run(densepack.Scene.from_toml(scenes / "walls_8_spheres.toml"), progress=False)
    image = packing.voxels(20)
    assert image.shape == (20, 20, 20) and image.dtype == np.uint8
    # Voxel volume fraction within the first-order resolution bound of the exact one.
    report = packing.export(tmp_path / "v.npy", "npy", voxels=20)
    assert np.array_equal(np.load(tmp_path / "v.npy"), image)
    assert abs(report["packing_fraction_voxels"] - packing.packing_fraction) <= report["resolution_bound"]
    labels = packing.voxels(20, "particle")
    assert labels.dtype == np.uint32 and set(np.unique(labels)) <= set(range(9))
    fractions = packing.voxels(10, partial_volume=4)
    assert fractions.dtype == np.float32
    packing.export(tmp_path / "p.csv", "csv")
    table = np.loadtxt(tmp_path / "p.csv", delimiter=",", skiprows=1, comments="#")
    assert np.allclose(table[:, :3], packing.centers, rtol=0, atol=1e-12)
    packing.export(tmp_path / "p.xyzd", "xyzd")
    xyzd = np.fromfile(tmp_path / "p.xyzd", dtype="<f8").reshape(-1, 4)
    assert np.array_equal(xyzd[:, :3], packing.centers)
    assert np.array_equal(xyzd[:, 3], 2 * packing.radii)
    report = packing.export(tmp_path / "v.vti", "vti", voxels=20)
    assert report["sidecar"] is None and list(report["shape"]) == [20, 20, 20]
    with pytest.raises(ValueError, match="voxels"):
        packing.export(tmp_path / "p2.csv", "csv", voxels=8)
    with pytest.raises(ValueError, match="gmsh, vtk, vti, abaqus, npy, raw, csv, xyzd, lammps"):
        packing.export(tmp_path / "p.xyz", "xyz")
    assert not (tmp_path / "p2.csv").exists()


def test_verify_reports_an_overlap_it_did_not_compute_itself(scenes):
    packing = densepack.run(densepack.Scene.from_toml(scenes / "walls_8_spheres.toml"), progress=False)
    assert packing.verify()["ok"]
    record = json.loads(packing.to_json())
    record["particles"][1]["center"] = record["particles"][0]["center"]
    broken = densepack.Packing.from_json(json.dumps(record))
    report = broken.verify()
    assert not report["ok"] and report["overlap_count"] >= 1


def test_take_draws_the_clis_diameters(cli, tmp_path):
    diameters, summary = densepack.take("B16", phi_m=0.7, d_min=2.0, box=(50, 50, 50), seed=3)
    sizes = tmp_path / "sizes.txt"
    subprocess.run(
        [cli, "take", "B16", "--phi-m", "0.7", "--d-min", "2", "--box", "50,50,50",
         "--seed", "3", "--sizes", str(sizes)],
        check=True, capture_output=True,
    )
    assert np.array_equal(diameters, np.loadtxt(sizes))
    # The draw reaches the target aggregate volume and exceeds it by less than one grain.
    volume = (np.pi / 6 * diameters**3).sum()
    assert summary["aggregate_volume"] <= volume < summary["aggregate_volume"] + np.pi / 6 * diameters.max() ** 3
    assert diameters.min() >= 2.0 and diameters.max() <= 16.0
    with pytest.raises(ValueError, match="phi_m|mixture fraction"):
        densepack.take("B16", phi_m=1.5, d_min=2.0, box=(50, 50, 50))


def test_foreign_files_import_and_round_trip(scenes, tmp_path):
    packing = densepack.run(densepack.Scene.from_toml(scenes / "sample_spheres.toml"), progress=False)
    edges = np.array(packing.container["max"]) - np.array(packing.container["min"])
    packing.export(tmp_path / "p.xyzd", "xyzd")
    back = densepack.Packing.import_file(
        tmp_path / "p.xyzd", "xyzd", box=tuple(edges), periodic=(True, True, True)
    )
    # The exported centres are relative to the box's lower corner, as the import's box.
    assert np.array_equal(back.centers, packing.centers - np.array(packing.container["min"]))
    assert np.array_equal(back.radii, packing.radii)
    assert back.verify()["ok"] and back.min_gap == 0.0
    assert back.provenance["imported_from"]["format"] == "xyzd"
    (tmp_path / "bad.csv").write_text("x,y,z,r\n1,2,3,0.5\n1,2,oops,0.5\n")
    with pytest.raises(ValueError, match="line 3"):
        densepack.Packing.import_file(tmp_path / "bad.csv", "csv", box=(10, 10, 10))
    with pytest.raises(ValueError, match="source"):
        densepack.Packing.import_file(tmp_path / "bad.csv", "pdb", box=(10, 10, 10))
    with pytest.raises(ValueError, match="box"):
        densepack.Packing.import_file(tmp_path / "bad.csv", "csv", box=(10, 10))
