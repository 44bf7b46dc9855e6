"""``microg sim``: the physics on its own, without a study."""

from __future__ import annotations

import click


@click.group()
def sim() -> None:
    """The physics core on its own: scripted demonstrations of the interaction model."""


@sim.command()
@click.option("--interaction", type=click.Choice(["impulse_penetration", "penetration_only", "soft_hand"]),
              default="impulse_penetration", show_default=True, help="Interaction model to run.")
@click.option("--gravity", type=float, default=0.0, show_default=True,
              help="Downward gravity in m/s^2 (0: microgravity; 9.81: Earth).")
@click.option("--object", "object_name", default="cube", show_default=True, help="Shipped object to carry.")
@click.option("--every", type=float, default=0.25, show_default=True, help="Print interval (s).")
def demo(interaction: str, gravity: float, object_name: str, every: float) -> None:
    """Pinch an object between thumb and index, carry it, let go, and print its motion.

    A scripted hand (two fingertips) closes on the object's sides, squeezes 5 mm into them,
    carries it 15 cm sideways and 10 cm up with a minimum-jerk motion, and opens. In
    microgravity the released object keeps drifting with whatever velocity it had when the
    fingers let go; under gravity it starts on a table and falls back onto it.
    """
    import numpy as np

    from microg.paths import object_file
    from microg.sim import (HandFrame, PlacedObject, TableParameters, compose_scene, grasped, load_object,
                            make_world, object_states, step)
    from microg.participant.scripted import pinch_and_carry, probe_hand

    spec = load_object(object_file(object_name))
    start = np.array([0.0, 0.2, 0.0])
    table = TableParameters(height=start[1] - spec.half_extents[1]) if gravity else None
    world = make_world(compose_scene([PlacedObject(spec, tuple(start))], interaction, gravity=(0.0, -gravity, 0.0),
                                     table=table))
    # Two contacts hold the weight when 2 mu gamma depth >= m g (Eq. 19); squeeze with a margin.
    gamma, mu = world.model.penetration_stiffness, spec.material.static_friction
    depth = max(0.005, 1.6 * spec.mass * gravity / (2 * mu * gamma)) if interaction != "soft_hand" else 0.005
    path, released = pinch_and_carry(start, spec.half_extents[0], carry=(0.15, 0.10, 0.0), depth=depth)
    rate = world.model.scene.tracking_rate
    click.echo(f"{spec.name} ({spec.mass:.3f} kg) in {'microgravity' if gravity == 0 else f'g = {gravity} m/s^2'}, "
               f"interaction model {interaction}, tracking {rate:.0f} Hz, physics dt {world.model.dt * 1e3:.2f} ms, "
               f"fingers squeeze {depth * 1e3:.1f} mm deep")
    click.echo(f"{'t (s)':>6} {'grasped':>7} {'x (m)':>8} {'y (m)':>8} {'z (m)':>8} "
               f"{'vx (m/s)':>9} {'vy (m/s)':>9} {'vz (m/s)':>9} {'|w| (rad/s)':>11}")
    next_print = 0.0
    for t in np.arange(0.0, released + 1.0 + 1e-9, 1.0 / rate):
        world = step(world, HandFrame(float(t), (probe_hand(path(t)),)))
        if t + 1e-9 >= next_print:
            state = object_states(world)[spec.name]
            p, v, w = state["position"], state["velocity"], state["angular_velocity"]
            click.echo(f"{t:6.2f} {'yes' if grasped(world)[0] else 'no':>7} {p[0]:8.4f} {p[1]:8.4f} {p[2]:8.4f} "
                       f"{v[0]:9.4f} {v[1]:9.4f} {v[2]:9.4f} {np.linalg.norm(w):11.4f}")
            next_print += every
    click.echo(f"the fingers let go at t = {released:.2f} s")


COMMANDS = [sim]
