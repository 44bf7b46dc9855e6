"""The physics core: hand model, contact, interaction models and world stepping (paper, section 3).

    from microg.sim import make_world, step
    world = make_world(scene)
    world = step(world, hand_frame)

Plain data (``Scene``, ``World``) and functions that advance it; no study logic lives here.
"""

from .bodies import Material, ObjectSpec, SceneError, load_object
from .hand import BONES, DIGITS, SIDES, SLOTS, Hand, HandFrame, slot, slot_name
from .observe import (angular_momentum, grasped, highlighted, kinetic_energy, object_states,
                      rendered_phalanges, touching)
from .scene import (EFFECTS, INTERACTION_MODELS, PlacedObject, Scene, TableParameters, compose_scene, load_scene,
                    with_interaction)
from .world import World, make_world, step

__all__ = [
    "BONES", "DIGITS", "EFFECTS", "INTERACTION_MODELS", "SIDES", "SLOTS", "Hand", "HandFrame", "Material",
    "ObjectSpec", "PlacedObject", "Scene", "SceneError", "TableParameters", "World", "angular_momentum", "compose_scene",
    "grasped", "highlighted", "kinetic_energy", "load_object", "load_scene", "make_world", "object_states",
    "rendered_phalanges", "slot", "slot_name", "step", "touching", "with_interaction",
]
