"""glTF, USD and video written from real recorded runs, read back with other libraries."""

import numpy as np
import pytest

from signorini import output, scenes
from signorini.export import write_gltf, write_usd
from signorini.render import default_camera, render_frame, video_frames, write_video


@pytest.fixture(scope="module", params=["boxes", "shapes"])
def record(request):
    """A short run of a built-in scene, with a stride so frames and steps differ."""
    return output.run(scenes.build(request.param), steps=60, progress=False, stride=4)


def accessor_array(gltf, index):
    """An accessor's data as a NumPy array (float32 or uint32), via pygltflib's binary blob."""
    import pygltflib as g

    accessor = gltf.accessors[index]
    view = gltf.bufferViews[accessor.bufferView]
    blob = gltf.binary_blob()
    dtype = np.float32 if accessor.componentType == g.FLOAT else np.uint32
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[accessor.type]
    start = view.byteOffset + (accessor.byteOffset or 0)
    data = np.frombuffer(blob[start:start + accessor.count * width * 4], dtype=dtype)
    return data.reshape(accessor.count, width) if width > 1 else data


def test_gltf_has_one_animated_node_per_dynamic_body(tmp_path, record):
    import pygltflib
    import trimesh

    path = write_gltf(tmp_path / "run.glb", record)
    gltf = pygltflib.GLTF2().load(str(path))
    n = record.num_bodies
    assert [node.name for node in gltf.nodes] == record.names + ["world"]
    # the root turns the simulator's up, +z here, onto glTF's +y: -90 degrees about x
    root = gltf.nodes[n]
    assert gltf.scenes[0].nodes == [n] and root.children == list(range(n))
    np.testing.assert_allclose(root.rotation, [-np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)], atol=1e-12)
    (animation,) = gltf.animations
    animated = {}
    for channel in animation.channels:
        sampler = animation.samplers[channel.sampler]
        animated.setdefault(channel.target.node, {})[channel.target.path] = (
            accessor_array(gltf, sampler.input), accessor_array(gltf, sampler.output))
    assert sorted(animated) == record.dynamic
    for i, paths in animated.items():
        times, translation = paths["translation"]
        _, rotation = paths["rotation"]
        np.testing.assert_allclose(times, record.time, atol=1e-6)
        np.testing.assert_allclose(translation, record.positions[:, i], atol=1e-6)
        # glTF quaternions are (x, y, z, w)
        np.testing.assert_allclose(rotation, record.orientations[:, i][:, [1, 2, 3, 0]], atol=1e-6)
    # each node's mesh is the body's draw mesh
    for i, node in enumerate(gltf.nodes[:n]):
        primitive = gltf.meshes[node.mesh].primitives[0]
        np.testing.assert_allclose(accessor_array(gltf, primitive.attributes.POSITION), record.draw_meshes[i][0],
                                   atol=1e-6)
        np.testing.assert_array_equal(accessor_array(gltf, primitive.indices).reshape(-1, 3), record.draw_meshes[i][1])

    # another reader agrees: one geometry per body
    scene = trimesh.load(str(path))
    assert len(scene.geometry) == record.num_bodies


def test_usd_has_one_xform_per_body_with_time_samples(tmp_path, record):
    from pxr import Usd, UsdGeom

    path = write_usd(tmp_path / "run.usda", record)
    stage = Usd.Stage.Open(str(path))
    assert stage.GetTimeCodesPerSecond() == pytest.approx(1.0 / record.dt)
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    for i, name in enumerate(record.names):
        xform = UsdGeom.Xformable(stage.GetPrimAtPath(f"/World/{name}"))
        translate, orient = xform.GetOrderedXformOps()
        assert translate.GetOpName() == "xformOp:translate" and orient.GetOpName() == "xformOp:orient"
        if record.is_static[i]:
            np.testing.assert_array_equal(np.array(translate.Get()), record.positions[0, i])
            continue
        codes = translate.GetTimeSamples()
        np.testing.assert_array_equal(codes, record.frame_step)
        assert orient.GetTimeSamples() == codes
        positions = np.array([np.array(translate.Get(c)) for c in codes])
        quats = np.array([[orient.Get(c).GetReal(), *orient.Get(c).GetImaginary()] for c in codes])
        np.testing.assert_array_equal(positions, record.positions[:, i])
        np.testing.assert_array_equal(quats, record.orientations[:, i])
        # seconds = time code / timeCodesPerSecond are the frame times
        np.testing.assert_allclose(np.array(codes) / stage.GetTimeCodesPerSecond(), record.time, atol=1e-12)
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/World/{name}/geom"))
        np.testing.assert_allclose(np.array(mesh.GetPointsAttr().Get()), record.draw_meshes[i][0], atol=1e-6)


@pytest.mark.slow
def test_video_frame_count_and_size(tmp_path, record):
    import imageio.v2 as imageio

    fps, size = 48.0, (320, 240)
    path = write_video(tmp_path / "run.mp4", record, fps=fps, size=size, progress=False)
    reader = imageio.get_reader(path)
    frames = [f for f in reader]
    reader.close()
    # 60 steps of 1/240 s = 0.25 s at 48 pictures per second: 13 pictures (t = 0 included)
    assert len(frames) == len(video_frames(record, fps)) == 13
    assert frames[0].shape == (240, 320, 3)
    # the first and last pictures differ: the bodies moved
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 0.1


def test_rendered_frames_show_the_bodies_where_they_are(record):
    camera = default_camera(record, follow=False)
    still = render_frame(record, 0, camera, (160, 120))
    assert still.shape == (120, 160, 3) and still.dtype == np.uint8
    assert np.array_equal(still, render_frame(record, 0, camera, (160, 120)))
    assert not np.array_equal(still, render_frame(record, record.frames - 1, camera, (160, 120)))


def test_bad_video_size_is_an_error(tmp_path, record):
    with pytest.raises(ValueError, match="even"):
        write_video(tmp_path / "x.mp4", record, size=(321, 240))
