"""Scenes compose only the effects they name; bad scenes and frames are refused with clear errors."""

import io
import re

import numba
import numpy as np
import pytest

from microg.skeleton import Hand, HandFrame
from microg.sim import (INTERACTION_MODELS, Material, ObjectSpec, PlacedObject, Scene, SceneError, TableParameters,
                        compose_scene, load_object, load_scene, make_world, stack_frames, step)
from microg.sim.pipeline import specialise
from tests.physics import drive, placed, world_of

KERNELS = ("sweep", "detect", "apply_impulses", "spring_onsets", "friction_cone", "penetration_forces",
           "soft_hand_forces", "add_gravity", "table_contacts", "update_velocity", "update_position", "rotate_free", "rotate_constant")
"""Every kernel the step can call (``pipeline.specialise``)."""


def step_signature(world) -> tuple:
    """The types of the arguments the world's step is called with (``pipeline.step_worlds``: the model's
    parameters, one world's buffers and one frame). Taken from the arguments, not from the step's own
    compiled signatures: a step called from a batch loop that numba loaded from its disk cache was
    never compiled on its own."""
    model, data = world.model, world.data
    frame = stack_frames((HandFrame(world.time),))[0]
    return tuple(numba.typeof(a) for a in (model.params, model.ints, data.reals, data.flags, data.counts, frame))


def compiled_kernels(world) -> set[str]:
    """The kernels that the world's compiled step calls, read from numba's typed code.

    The step's function is compiled afresh (without the disk cache, whose code cannot be read
    back) for the arguments the world passes; numba prunes the branches of unnamed effects before
    typing, so a kernel appears in the typed code exactly when the machine code calls it."""
    step = world.model.step
    fresh = numba.njit(step.py_func, error_model="numpy")
    signature = step_signature(world)
    fresh.compile(signature)
    typed = io.StringIO()
    fresh.inspect_types(file=typed, signature=signature)
    return {name for name in KERNELS if re.search(rf"global\({name}: CPUDispatcher", typed.getvalue())}


MESH_KERNELS = ("mesh_closest_point", "mesh_over_face", "mesh_project", "mesh_segment_entry", "mesh_along_face",
                "unpack_mesh")
"""The kernels of mesh objects (``mesh_contact``, ``state.unpack_mesh``)."""


def linked_code(world) -> str:
    """The LLVM code of the world's compiled step with every kernel it calls, at any depth (numba
    links each called kernel's code into its caller's), compiled afresh as ``compiled_kernels``."""
    step = world.model.step
    fresh = numba.njit(step.py_func, error_model="numpy")
    signature = step_signature(world)
    fresh.compile(signature)
    return fresh.inspect_llvm(signature)


def pinch_path(t):
    x = 0.03 + 0.008 + 0.005 - min(t, 0.3) / 0.3 * 0.009
    return {"thumb.distal": (-x, 0.2, 0.0), "index.distal": (x, 0.2, 0.0)}


def test_kernels_of_effects_not_named_are_not_in_the_compiled_step():
    world = drive(world_of([placed("cube")], effects={"penetration"}), pinch_path, t_end=0.5)
    assert world.data.active.any()
    assert compiled_kernels(world) == {"detect", "spring_onsets", "penetration_forces", "update_velocity",
                                       "update_position", "rotate_constant"}


def test_every_named_effect_is_in_the_compiled_step():
    world = drive(world_of([placed("cube")], interaction="impulse_penetration", gravity=(0.0, -9.81, 0.0)),
                  pinch_path, t_end=0.1)
    assert compiled_kernels(world) == {"sweep", "detect", "apply_impulses", "friction_cone", "penetration_forces",
                                       "add_gravity", "update_velocity", "update_position", "rotate_free"}


def test_mesh_kernels_are_in_the_compiled_step_only_when_the_scene_has_a_mesh(tmp_path):
    import trimesh

    from tests.meshes import mesh_object

    box = trimesh.creation.box(extents=(0.06, 0.06, 0.06))
    cube_mesh = PlacedObject(load_object(mesh_object(tmp_path, "cube", box.vertices, box.faces, mass=0.15)),
                             (0.0, 0.2, 0.0))
    effects = {"impulse", "penetration", "friction", "continuous_collision", "table"}
    options = {"table": TableParameters(height=0.1)}
    for objects, meshes in (([placed("cube"), placed("ball", (0.2, 0.2, 0.0))], False), ([cube_mesh], True)):
        world = drive(world_of(objects, effects=effects, **options), pinch_path, t_end=0.05)
        code = linked_code(world)
        assert re.search(r"\d+detect[BE]", code) and re.search(r"\d+table_contacts[BE]", code)
        assert {name for name in MESH_KERNELS if re.search(rf"\d+{name}[BE]", code)} == (
            set(MESH_KERNELS) if meshes else set())


def test_each_set_of_effects_compiles_once():
    scene = compose_scene([placed("cube")], "soft_hand")
    assert make_world(scene).model.step is make_world(scene).model.step
    assert specialise(scene.effects) is not specialise(compose_scene([placed("cube")]).effects)


def test_interaction_models_are_the_documented_compositions():
    assert INTERACTION_MODELS["impulse_penetration"] == {"impulse", "penetration", "friction"}
    assert INTERACTION_MODELS["penetration_only"] == {"penetration", "friction"}
    assert INTERACTION_MODELS["soft_hand"] == {"soft_hand", "friction"}


def good_scene(**changes):
    spec = changes.pop("spec", ObjectSpec("cube", "box", (0.06, 0.06, 0.06), 0.15))
    placement = {"position": (0.0, 0.2, 0.0), **changes.pop("placement", {})}
    return Scene(objects=(PlacedObject(spec, **placement),), effects=frozenset(changes.pop("effects", {"penetration"})),
                 **changes)


@pytest.mark.parametrize("scene, message", [
    (good_scene(placement={"position": (np.nan, 0.2, 0.0)}), "objects[0] (cube).position = [nan, 0.2, 0.0]"),
    (good_scene(placement={"orientation": (0.0, 0.0, 0.0, 0.0)}), "orientation = [0.0, 0.0, 0.0, 0.0]"),
    (good_scene(spec=ObjectSpec("cube", "box", (0.06, 0.06, 0.06), -1.0)), "mass = -1.0"),
    (good_scene(spec=ObjectSpec("cube", "box", (0.06, 0.0, 0.06), 0.15)), "size.y = 0.0"),
    (good_scene(spec=ObjectSpec("rod", "box", (0.06, 0.06, 0.06), 0.15, inertia=(1e-4, 1e-4, 5e-4))),
     "inertia = [0.0001, 0.0001, 0.0005]"),
    (good_scene(effects={"penetration", "antigravity"}), "unknown effect 'antigravity'"),
    (good_scene(effects={"friction"}), "'friction' without a contact force"),
    (good_scene(gravity=(0.0, -9.81, 0.0)), "does not name 'gravity'"),
    (good_scene(spec=ObjectSpec("cube", "box", (0.06, 0.06, 0.06), 0.15, Material(1.2, 0.8, 0.5))),
     "restitution = 1.2"),
    (good_scene(spec=ObjectSpec("cube", "box", (0.06, 0.06, 0.06), 0.15, Material(0.4, 0.5, 0.8))),
     "dynamic_friction = 0.8"),
    (good_scene(substeps=0), "substeps = 0"),
    (good_scene(effects={"continuous_collision"}), "'continuous_collision' without a contact model"),
    (Scene(objects=(PlacedObject(ObjectSpec("cube", "box", (0.06, 0.06, 0.06), 0.15)),) * 2,
           effects=frozenset({"penetration"})), "two objects named 'cube'"),
])
def test_bad_scenes_name_the_field_and_value(scene, message):
    with pytest.raises(SceneError) as error:
        make_world(scene)
    assert message in str(error.value)


def test_bad_object_file_names_file_field_and_value(tmp_path):
    path = tmp_path / "cube.toml"
    path.write_text('name = "cube"\nshape = "box"\nsize = [0.06, 0.06, 0.06]\nmass = 0\n')
    with pytest.raises(SceneError, match=rf"{path}: mass = 0: must be a positive number"):
        load_object(path)
    path.write_text('name = "cube"\nshape = "cone"\nsize = [0.06, 0.06, 0.06]\nmass = 1\n')
    with pytest.raises(SceneError, match=r"cube.toml: shape = 'cone'"):
        load_object(path)


def test_scene_file_loads_objects_and_effects(tmp_path):
    from microg.paths import OBJECTS
    path = tmp_path / "scene.toml"
    path.write_text(f'interaction = "penetration_only"\neffects = ["gyroscopic"]\ngravity = [0, -9.81, 0]\n'
                    f'substeps = 2\n[[objects]]\nfile = "{OBJECTS / "cube.toml"}"\nposition = [0, 0.2, 0]\n')
    with pytest.raises(SceneError, match="does not name 'gravity'"):
        load_scene(path)
    path.write_text(path.read_text().replace('["gyroscopic"]', '["gyroscopic", "gravity"]'))
    scene = load_scene(path)
    assert scene.effects == {"penetration", "friction", "gyroscopic", "gravity"}
    assert scene.objects[0].spec.name == "cube" and scene.substeps == 2


@pytest.mark.parametrize("line, message", [
    ("[soft_hand]\nstiffnes = 300", "unknown field soft_hand.stiffnes"),
    ("table = 0.1", "table = 0.1: must be a table"),
    ("gravity = -9.81", "gravity = -9.81: must be three numbers"),
    ("[[objects]]\nfile = 'CUBE'\nposition = 0.2", "objects[0].position = 0.2: must be a list"),
    ("[[objects]]\nfile = 'CUBE'\norientation_deg = [0, 45]", "objects[0].orientation_deg = [0, 45]"),
])
def test_bad_scene_file_names_file_field_and_value(tmp_path, line, message):
    from microg.paths import OBJECTS
    path = tmp_path / "scene.toml"
    path.write_text('interaction = "impulse_penetration"\n' + line.replace("CUBE", str(OBJECTS / "cube.toml")) + "\n")
    with pytest.raises(SceneError) as error:
        load_scene(path)
    assert str(error.value).startswith(f"{path}: ") and message in str(error.value)


def test_zero_width_bone_is_refused_with_its_name():
    joints = np.full((5, 5, 3), np.nan)
    joints[1, 3], joints[1, 4] = (0.0, 0.2, 0.0), (0.0, 0.22, 0.0)
    widths = np.full((5, 4), np.nan)
    widths[1, 3] = 0.0
    with pytest.raises(ValueError, match=r"Hand\(right\).widths\[1, 3\] \(index distal\) = 0.0"):
        Hand("right", joints, widths, np.zeros(3))


def test_frames_out_of_order_are_refused_by_the_physics():
    world = world_of([placed("cube")])
    world = step(world, HandFrame(1.0))
    with pytest.raises(SceneError, match="timestamp 1.0 is not after"):
        step(world, HandFrame(1.0))


def test_step_leaves_its_input_untouched():
    world = world_of([placed("cube", velocity=(0.1, 0.0, 0.0))])
    world = step(world, HandFrame(0.0))
    before = world.data.position.copy()
    later = step(world, HandFrame(0.5))
    assert np.array_equal(world.data.position, before)
    assert later.data.position[0, 0] == pytest.approx(0.05)
