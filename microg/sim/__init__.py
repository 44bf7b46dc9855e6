"""The physics core: hand geometry, contact, interaction models and world stepping (paper, section 3).

    from microg.sim import make_world, step
    world = make_world(scene)
    world = step(world, hand_frame)

    batch = make_batch(scene, 256)
    batch = step_batch(batch, frames)     # one frame per world, one compiled call

Plain data (``Scene``, ``World``, ``Batch``) and functions that advance it; no study logic lives here.
Compiled code is cached in the user's cache directory (``microg.skeleton.cache``).
"""

import microg.skeleton  # noqa: F401  (first: it points numba at the user's cache before any kernel here is defined)

from .bodies import Material, ObjectSpec, SceneError, load_object  # noqa: E402
from .observe import (Snapshot, angular_momentum, grasped, highlighted, kinetic_energy,  # noqa: E402
                      object_states, rendered_phalanges, snapshot, touching)
from .scene import (EFFECTS, INTERACTION_MODELS, PlacedObject, Scene, TableParameters, compose_scene,  # noqa: E402
                    load_scene, with_interaction)
from .world import Batch, World, make_batch, make_world, stack_frames, step, step_batch  # noqa: E402

__all__ = [
    "EFFECTS", "INTERACTION_MODELS", "Batch",
    "Material", "ObjectSpec", "PlacedObject", "Scene", "SceneError", "Snapshot", "TableParameters", "World",
    "angular_momentum", "compose_scene", "grasped", "highlighted", "kinetic_energy", "load_object", "load_scene",
    "make_batch", "make_world", "object_states", "rendered_phalanges", "snapshot", "stack_frames", "step",
    "step_batch", "touching", "with_interaction",
]
