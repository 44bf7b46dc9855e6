"""``microg sim``: the physics on its own, without a study: the paper's demos one at a time
(``sim demo``) or under every interaction model side by side (``sim gallery``)."""

from __future__ import annotations

import csv
from pathlib import Path

import click
import numpy as np

from microg.participant.demos import DEMOS, DemoRun, run_demo
from microg.sim import INTERACTION_MODELS, SceneError
from microg.view import HAND_MODES

from .common import picture_size

GALLERY_TABLE = "gallery.csv"


@click.group()
def sim() -> None:
    """The physics core on its own: scripted demonstrations of the interaction model."""


@sim.command()
@click.argument("name", type=click.Choice(list(DEMOS)), default="pinch-carry")
@click.option("--interaction", type=click.Choice(list(INTERACTION_MODELS)), default="impulse_penetration",
              show_default=True, help="Interaction model to run.")
@click.option("--gravity", type=float, default=None,
              help="pinch-carry only: downward gravity in m/s^2 (default 0: microgravity; 9.81: Earth, the object "
                   "on a table). The other demos fix theirs (lift: 9.81, the rest: 0).")
@click.option("--object", "object_name", default=None, help="pinch-carry only: the shipped object to carry "
              "(default cube).")
@click.option("--every", type=float, default=0.25, show_default=True, help="Print interval (s).")
def demo(*, name: str, interaction: str, gravity: float | None, object_name: str | None, every: float) -> None:
    """Run one of the paper's demos (Fig. 8) with a scripted hand and print the object's motion.

    NAME is one of: ball-grasp (thumb and three fingers carry a floating ball), cube-grasp (thumb
    against two fingers carry a floating cube), flat-grasp (thumb below, two fingers above carry the
    flat cuboid), ball-catch (a ball thrown at the still, open hand is
    caught and held), pinch (thumb and index carry the long bar), lift (under Earth gravity, three
    digits lift the cube off the table and hold it), nudge (a fingertip taps a floating cube, which
    drifts and turns), pinch-carry (the default: thumb and index carry an object and let go; in
    microgravity it keeps drifting with the velocity it had when the fingers let go).
    """
    options = {key: value for key, value in (("gravity", gravity), ("object_name", object_name)) if value is not None}
    try:
        result = run_demo(name, interaction, **options)
    except (SceneError, FileNotFoundError) as error:
        raise click.ClickException(str(error)) from None
    scene = result.demo.scene(interaction)
    spec, g = result.demo.placed.spec, result.demo.gravity
    click.echo(f"{name}: {result.demo.description}")
    squeeze = f", fingers squeeze {result.demo.squeeze * 1e3:.1f} mm deep" if result.demo.squeeze else ""
    click.echo(f"{spec.name} ({spec.mass:.3f} kg) in {'microgravity' if g == 0 else f'g = {g} m/s^2'}, interaction "
               f"model {interaction}, tracking {scene.tracking_rate:.0f} Hz, physics dt {scene.dt * 1e3:.2f} ms"
               f"{squeeze}")
    click.echo(f"{'t (s)':>6} {'grasped':>7} {'x (m)':>8} {'y (m)':>8} {'z (m)':>8} "
               f"{'vx (m/s)':>9} {'vy (m/s)':>9} {'vz (m/s)':>9} {'|w| (rad/s)':>11}")
    next_print = 0.0
    for i, t in enumerate(result.t):
        if t + 1e-9 >= next_print:
            p, v, w = result.position[i], result.velocity[i], result.angular_velocity[i]
            click.echo(f"{t:6.2f} {'yes' if result.grasped[i] else 'no':>7} {p[0]:8.4f} {p[1]:8.4f} {p[2]:8.4f} "
                       f"{v[0]:9.4f} {v[1]:9.4f} {v[2]:9.4f} {np.linalg.norm(w):11.4f}")
            next_print += every
    click.echo("key moments: " + ", ".join(f"{label} {t:.2f} s" for label, t in result.demo.moments))
    click.echo(_summary_line(result))


@sim.command()
@click.option("--out", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the pictures and gallery.csv (created; must be empty unless --overwrite).")
@click.option("--demos", "names", default=",".join(DEMOS), show_default=True,
              help="The demos to run, comma-separated.")
@click.option("--hands", type=click.Choice(HAND_MODES), default="rendered", show_default=True,
              help="Draw the rendered (god-object) hand, the tracked hand, or both (tracked faint).")
@click.option("--size", default="320x240", show_default=True, help="Pixels of one panel or animation frame.")
@click.option("--fps", type=click.FloatRange(min=0.0, min_open=True), default=10.0, show_default=True,
              help="Animation frames per second (real time).")
@click.option("--overwrite", is_flag=True, help="Write into a non-empty --out, replacing the gallery's own files.")
@click.option("--quiet", is_flag=True, help="No progress lines.")
def gallery(*, out: Path, names: str, hands: str, size: str, fps: float, overwrite: bool, quiet: bool) -> None:
    """Run each demo under every interaction model and put the models side by side, as the paper's
    Fig. 7 compares its model with CLAP.

    For each demo it writes DEMO.png, an image strip with a row per interaction model and a column
    per key moment, and DEMO.gif, the models side by side in real time; gallery.csv has one row per
    demo and model: demo, interaction, grasped (held at the end), attempts (holds lost while the
    script held on), peak_object_speed_m_s, deepest_penetration_mm (of a tracked phalanx into the
    object).
    """
    chosen = _demo_names(names)
    pixels = picture_size(size)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not overwrite:
        raise click.ClickException(f"{out} exists and is not empty; choose another --out or pass --overwrite")
    out.mkdir(parents=True, exist_ok=True)
    say = (lambda text: None) if quiet else click.echo
    total, done, rows = len(chosen) * len(INTERACTION_MODELS), 0, []
    for name in chosen:
        results = {}
        for interaction in INTERACTION_MODELS:
            results[interaction] = run_demo(name, interaction)
            rows.append(results[interaction].summary())
            done += 1
            say(f"[{done}/{total}] {name}, {interaction}: {_summary_line(results[interaction])}")
        strip, animation = _draw(results, out, hands=hands, size=pixels, fps=fps)
        say(f"wrote {strip} and {animation}")
    table = out / GALLERY_TABLE
    with table.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    say(f"wrote {table}")


def _demo_names(text: str) -> list[str]:
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in DEMOS]
    if unknown or not names:
        raise click.BadParameter(f"{unknown[0] if unknown else text!r}: give demos from {', '.join(DEMOS)}, "
                                 "comma-separated", param_hint="--demos")
    return names


def _summary_line(result: DemoRun) -> str:
    summary = result.summary()
    return (f"{'held' if summary['grasped'] else 'not held'} at the end, {summary['attempts']} attempts (drops), peak object "
            f"speed {summary['peak_object_speed_m_s']:.3f} m/s, deepest penetration "
            f"{summary['deepest_penetration_mm']:.1f} mm")


def _draw(results: dict[str, DemoRun], out: Path, *, hands: str, size: tuple[int, int],
          fps: float) -> tuple[Path, Path]:
    """The demo's strip (a row per model, a column per key moment) and its animation (the models
    side by side), framed by one camera that sees the object and the hand in every run."""
    from microg.view.picture import write_comparison_animation, write_comparison_strip
    from microg.view.scene import framing_camera, object_layout

    demo = next(iter(results.values())).demo
    spec = demo.placed.spec
    layout = object_layout(spec, demo.placed.position, demo.table.height if demo.table else None)
    seen = np.vstack([np.vstack([r.position, r.rendered[np.isfinite(r.rendered).all(axis=-1)]])
                      for r in results.values()])
    camera = framing_camera(seen, margin=float(np.linalg.norm(spec.half_extents)), aspect=size[0] / size[1])
    moments = {model: [_scene(r, r.index_at(t)) for _, t in demo.moments] for model, r in results.items()}
    strip = write_comparison_strip(moments, [label for label, _ in demo.moments], layout=layout, camera=camera,
                                   out=out / f"{demo.name}.png", hands=hands, size=size,
                                   title=f"{demo.name}: {demo.description}")
    times = np.arange(0.0, demo.duration + 1e-9, 1.0 / fps)
    frames = {model: [_scene(r, r.index_at(t)) for t in times] for model, r in results.items()}
    animation = write_comparison_animation(frames, layout, camera=camera, out=out / f"{demo.name}.gif", hands=hands,
                                           size=size, fps=fps)
    return strip, animation


def _scene(result: DemoRun, i: int):
    """Frame ``i`` of a demo as the view draws it."""
    from microg.view.scene import world_scene

    return world_scene(float(result.t[i]), object_position=result.position[i],
                       object_orientation=result.orientation[i], joints=result.joints[i], widths=result.widths[i],
                       rendered=result.rendered[i], touching=result.touching[i], held=bool(result.grasped[i]))


COMMANDS = [sim]
