"""The 3D view of a study's sessions (the paper's mixed-reality scene, Figs. 1, 7 and 9).

- ``serve(study_dir, spec=SESSION)`` (``microg view``): a browser view on 127.0.0.1 that follows a
  running session or replays a logged one (``server``), reading the study's database read-only
  while the session writes it (``track``).
- ``export_task(...)`` (``microg view export``): an image strip of a task's key moments or an
  animation, drawn headless (``picture``).

Both draw the same ``FrameScene`` (``scene``): the tracked and the rendered (god-object) hand,
the contact highlight, the object, the place markers and the heads-up display.
"""

from __future__ import annotations

from pathlib import Path

from .scene import HAND_MODES, FrameScene, TaskLayout, default_camera, task_layout
from .track import KeyMoment, Track, find_run, find_session, key_moments, open_readonly, read_track

__all__ = ["HAND_MODES", "FrameScene", "KeyMoment", "TaskLayout", "Track", "default_camera", "export_task", "find_run",
           "find_session", "key_moments", "open_readonly", "read_track", "serve", "task_layout"]


def serve(*args, **kwargs):
    """See ``microg.view.server.serve`` (imported on use: it needs viser)."""
    from .server import serve as run

    return run(*args, **kwargs)


def export_task(study_dir: str | Path, session: str, task_index: int, out: str | Path, *, run: int | None = None,
                hands: str = "rendered", seconds: tuple[float, ...] = (), size: tuple[int, int] = (480, 360),
                fps: float = 15.0, speed: float = 1.0, title: bool = True, overwrite: bool = False,
                progress: bool = True, say=print) -> Path:
    """Pictures of one task run: an image strip (``out`` .png, .pdf, .svg) of its key moments, or
    of the frames at ``seconds`` into the task; or an animation (.gif, .webp). An existing ``out``
    is replaced only with ``overwrite``. ``say`` gets a warning line for each problem of a damaged study."""
    from .picture import ANIMATION_FORMATS, STRIP_FORMATS, write_animation, write_strip

    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in STRIP_FORMATS + ANIMATION_FORMATS:
        raise ValueError(f"--out {out}: choose a strip ({', '.join(STRIP_FORMATS)}) or an animation "
                         f"({', '.join(ANIMATION_FORMATS)})")
    if hands not in HAND_MODES:
        raise ValueError(f"hands = {hands!r}: must be one of {HAND_MODES}")
    if seconds and suffix in ANIMATION_FORMATS:
        raise ValueError(f"--at chooses the panels of a strip; an animation ({out}) shows the whole task")
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out} exists; choose another --out or pass --overwrite")
    with open_readonly(study_dir) as store:
        for problem in store.problems:
            say(f"warning: the study is damaged: {problem}")
        record = find_session(store, session)
        if record is None:
            raise ValueError(f"--session {session}: participant {session} has no session yet")
        track = read_track(store, find_run(store, record, task_index, run))
        layout = task_layout(store.protocol, track.run.object, track.run.phase)
    outside = [t for t in seconds if not 0.0 <= t <= track.duration]
    if outside:
        raise ValueError(f"--at {outside[0]:g}: task {task_index} of {record.participant_id} lasts "
                         f"{track.duration:.2f} s (give 0 to {track.duration:.2f})")
    camera = default_camera(layout, aspect=size[0] / size[1])
    if suffix in ANIMATION_FORMATS:
        return write_animation(track, layout, camera=camera, out=out, hands=hands, size=size, fps=fps, speed=speed,
                               progress=progress)
    moments = ([KeyMoment(f"{t:g} s", track.index_at(t)) for t in seconds] if seconds
               else key_moments(track, len(layout.places), layout.kind))
    return write_strip(track, layout, camera=camera, moments=moments, out=out, hands=hands, size=size, title=title)
