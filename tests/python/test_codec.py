"""The codec: rotations are the World's own to the bit, bad rotations are clear errors, and every
shape survives the data form (what scene files, trajectories and the fuzzer hold) exactly."""
import numpy as np
import pytest

import signorini as sg
from signorini import codec, meshes


def test_quat_to_matrix_is_the_worlds_rotation_to_the_bit():
    rng = np.random.default_rng(20)
    w = sg.World()
    w.add_static(sg.Sphere(1.0))
    for _ in range(500):
        q = rng.normal(size=4) * rng.uniform(0.01, 100.0)  # not unit: made unit as the World does
        w.set_orientation(0, q)
        R = codec.quat_to_matrix(q)
        assert np.array_equal(R, w.rotations[0])
        back = codec.matrix_to_quat(R)
        assert back[0] >= 0.0 and np.allclose(back, w.orientations[0], rtol=0, atol=4e-16)


@pytest.mark.parametrize("call, value, message", [
    (codec.quat_to_matrix, [1.0, 0.0, 0.0], "q must have shape (4,), got shape (3,)"),
    (codec.quat_to_matrix, [0.0, 0.0, 0.0, 0.0], "is zero; use (1, 0, 0, 0) for no rotation"),
    (codec.quat_to_matrix, [np.nan, 0.0, 0.0, 1.0], "must be finite"),
    (codec.matrix_to_quat, np.eye(4), "R must have shape (3, 3), got shape (4, 4)"),
    (codec.matrix_to_quat, np.zeros((3, 3)), "rotation matrix is zero"),
    (codec.matrix_to_quat, np.diag([1.0, np.inf, 1.0]), "rotation matrix must be finite"),
])
def test_bad_rotations_are_value_errors_naming_the_problem(call, value, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call(value)


def every_shape():
    v, f = meshes.box_mesh((0.1, 0.2, 0.3))
    tv, tf = meshes.torus(0.3, 0.1, 12, 6)
    return [sg.Sphere(0.5), sg.Box((0.1, 0.2, 0.3)), sg.Plane((0.0, 0.6, 0.8), -0.25), sg.Capsule(0.1, 0.4),
            sg.Cylinder(0.2, 0.3), sg.ConvexHull(np.random.default_rng(1).normal(size=(12, 3))),
            sg.Mesh(v, f), sg.Mesh(tv, tf).with_pieces([tv[:8], tv[8:20]]), sg.TriangleMesh(v, f),
            sg.Compound([(sg.Box((0.1, 0.05, 0.02)), ((0.0, 0.0, 0.0), (1, 0, 0, 0))),
                         (sg.Sphere(0.04), ((0.1, 0.0, 0.05), (0.9, 0.1, 0.2, 0.3)))])]


@pytest.mark.parametrize("shape", every_shape(), ids=lambda s: type(s).__name__)
def test_every_shape_round_trips_through_the_data_form(shape):
    files = {}

    def mesh_file(vertices, faces, pieces):
        files[f"m{len(files)}"] = (np.array(vertices), np.array(faces), [np.array(p) for p in pieces])
        return f"m{len(files) - 1}"

    data = codec.shape_to_data(shape, mesh_file, exact=True)
    back = codec.shape_from_data(data, lambda d, where: files[d["file"]])
    a, b = codec.shape_to_dict(shape), codec.shape_to_dict(back)
    assert a["type"] == b["type"] == codec.shape_kind(shape)
    flat = lambda d: [np.asarray(x, dtype=float) for k, x in sorted(d.items()) if k not in ("type", "parts", "pieces")]
    assert all(np.array_equal(x, y) for x, y in zip(flat(a), flat(b)))
    assert len(a.get("pieces", [])) == len(b.get("pieces", []))
    for (da, pa, Ra), (db, pb, Rb) in zip(a.get("parts", []), b.get("parts", [])):
        assert da["type"] == db["type"] and np.array_equal(pa, pb) and np.array_equal(Ra, Rb)
    # without a mesh file a mesh gives its sizes (trajectories draw it from its draw mesh)
    if a["type"] in ("mesh", "hull", "trimesh"):
        assert codec.shape_to_data(shape) == {"type": a["type"], "num_vertices": len(shape.vertices),
                                              "num_faces": len(shape.faces)}


def test_bad_shape_data_names_the_key():
    with pytest.raises(ValueError, match=r"shape\.parts\[1\]\.shape: unknown shape type 'cone'"):
        codec.shape_from_data({"type": "compound", "parts": [{"shape": {"type": "sphere", "radius": 1.0}},
                                                             {"shape": {"type": "cone"}}]})
    with pytest.raises(ValueError, match=r"^shape: "):
        codec.shape_from_data({"type": "sphere", "radius": -1.0})
