"""``microg session run | resume``: run a participant's session from live, replayed or simulated hands,
with the participant's view served by the session itself (``--display``)."""

from __future__ import annotations

import contextlib
import signal
from dataclasses import dataclass

import click
from tqdm import tqdm

from microg.hands import SourceError
from microg.sim import INTERACTION_MODELS
from microg.study.inputs import PacedInputs, open_inputs, parse_input, participant_plan
from microg.study.protocol import FOV_RANGE, Phase
from microg.study.simulated_rater import SimulatedRater
from microg.study.questionnaire import TerminalRater
from microg.study.session import (EventLog, Outputs, Unattended, handling_stop_signals, make_clock, resume_session,
                                  run_session)
from microg.study.protocol import ProtocolError
from microg.study.replay import ReplayError, ReplayInputs
from microg.study.store import PlannedTask, Store, StoreError, describe_counts, open_study, plan_tasks

from .common import PAGE_OPTIONS, announce_page, clear_errors, page_certificate, study_dir_argument

QUESTIONNAIRE_DEFAULT = {"leap": "ask", "webxr": "ask", "lsl": "ask", "replay": "skip", "simulated": "model"}
LIVE = ("leap", "webxr", "lsl")
"""Inputs with a person at the tracker: the display is on by default."""


class TerminalOperator:
    """The researcher at the keyboard of a live session."""

    def present(self, phase: Phase) -> None:
        click.echo(f"\n== {phase.name} ({phase.minutes:g} min) ==")
        if phase.text.strip():
            click.echo(phase.text.strip())
        click.prompt("Press Enter when done", default="", show_default=False)

    def ready(self, task: PlannedTask) -> bool:
        answer = click.prompt(f"\nNext: {task.phase}, {task.object} ({task.object_code}), position "
                              f"{task.order_position}. Enter to start, s to skip", default="", show_default=False)
        return answer.strip().lower() != "s"

    def finished(self, task: PlannedTask, status: str, time_s: float | None) -> None:
        click.echo(f"task {task.index} {status}" + (f" in {time_s:.1f} s" if time_s is not None else ""))

    def progressed(self, text: str) -> None:
        click.echo(text)


@click.group("session")
def session() -> None:
    """Run and resume participants' sessions."""


@dataclass(frozen=True)
class SessionOptions:
    """What ``session run`` and ``session resume`` share (``session_options``): how the session asks
    its questionnaire, shows the participant's view, places replayed recordings and streams on LSL."""

    questionnaire: str | None
    display: bool | None
    """None: on for live input."""
    host: str
    port: int
    cert: str | None
    key: str | None
    qr: str | None
    eye: str | None
    look_at: str | None
    fov: float | None
    pace: float
    align: str | None
    lsl: bool
    quiet: bool


def _rejected_logger(log: EventLog):
    def rejected(question, text, message):
        instrument, administration, interaction, item = question.key
        log.emit("answer_rejected", {"instrument": instrument, "administration": administration,
                                     "interaction": interaction, "item": item, "answer": text, "message": message})
    return rejected


def _rater(kind: str, log: EventLog, seed: int, display):
    if kind == "skip":
        return None
    if kind == "ask":
        if display is not None:
            from microg.view.display import DisplayRater
            return DisplayRater(display, on_rejected=_rejected_logger(log))
        return TerminalRater(on_rejected=_rejected_logger(log))
    return SimulatedRater(log.store, log.session_id, seed)


def _point(text: str | None, name: str) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3:
        raise click.BadParameter(f"{text!r}: give three numbers X,Y,Z in metres (tracker frame)", param_hint=name)
    return values


def _run_one(store: Store, participant_id: str, *, input_spec: str | None, options: SessionOptions,
             resume: bool, session: str | None = None, ignore_schedule: bool = False) -> str:
    record = store.participant(participant_id)
    existing = store.session_of(participant_id)
    if resume and existing is None:
        raise click.ClickException(f"participant {participant_id} has no session to resume; start one with: "
                                   f"microg session run {store.dir} --participant {participant_id} --input ...")
    if resume and existing.status != "running":
        named = f" ({existing.name!r})" if store.protocol.program else ""
        raise click.ClickException(f"session {existing.id}{named} of {participant_id} is {existing.status}; there is "
                                   "nothing to resume" + (f" (their next session runs with: microg session run "
                                                          f"{store.dir} --participant {participant_id} --input ...)"
                                                          if named else ""))
    spec = input_spec or (existing.input if resume else None)
    if spec is None:
        raise click.ClickException("give --input leap, webxr, lsl:NAME, replay:FILE or simulated[:PROFILE]")
    kind = parse_input(spec)[0]
    shown = options.display if options.display is not None else kind in LIVE
    if kind == "webxr" and not shown:
        raise click.UsageError("--input webxr reads the hands from the participant's page: it needs --display")
    if resume:
        session_record = existing
        store.check_runs_here(participant_id)
    else:  # refused before anything opens: out of order, run before, not due yet
        planned = store.schedule_session(participant_id, simulated=kind == "simulated", session=session,
                                     ignore_schedule=ignore_schedule)[0].name
    rating = options.questionnaire or QUESTIONNAIRE_DEFAULT.get(kind, "skip")
    problems = store.protocol.simulation_problems() if kind == "simulated" or rating == "model" else []
    if problems:
        raise ProtocolError("a simulated participant cannot run this study's protocol:\n  " + "\n  ".join(problems))
    with contextlib.ExitStack() as stack:
        pause = stack.enter_context(_pause_on_signals())
        display = stack.enter_context(_display(store, options, kind)) if shown else None
        inputs = open_inputs(spec, store.protocol.group(record.group),
                             webxr=None if display is None else display.hands, align=options.align)
        stack.callback(inputs.close)
        if shown and kind not in LIVE:
            inputs = PacedInputs(inputs, options.pace)
        if isinstance(inputs, ReplayInputs):  # every task has its recording, before anything runs
            tasks = plan_tasks(store.protocol, record.group, record.object_order,
                               session_record.name if resume else planned)
            try:
                inputs.check([participant_plan(store.protocol, task, participant=participant_id) for task in tasks])
            except ReplayError as error:
                raise click.ClickException(str(error)) from None
        if not resume:
            session_record = store.create_session(participant_id, input_spec=inputs.spec, simulated=inputs.simulated,
                                                  clock=inputs.clock, session=planned,
                                                  ignore_schedule=ignore_schedule)
        store.lock_session(session_record.id)
        clock = make_clock(inputs.clock, store.last_time(session_record.id))
        log = EventLog(store, session_record.id, clock)
        rater = _rater(rating, log, session_record.seed, display)
        if rater is not None:
            rater = _Checked(rater, pause, waits=rating == "ask")
        markers, sinks = None, [pause]  # first: a frame after a signal feeds nothing more
        if options.lsl:
            from microg.study.lsl import NETWORK_NOTICE, MarkerOutlet, MocapOutlet, session_tags

            click.echo(NETWORK_NOTICE, err=True)
            tags = session_tags(store, session_record.id)
            try:
                markers = MarkerOutlet(tags, clock)
                sinks.append(MocapOutlet(store.protocol.tracking_rate, tags))
            except ImportError as error:
                raise click.ClickException(str(error)) from None
        operator = TerminalOperator() if kind in LIVE else Unattended()
        if display is not None:
            from microg.view.display import DisplayOperator
            operator = DisplayOperator(display, operator)
            display.on_event = log.emit  # what the page measured or decided: display_clock, display_placement
            sinks.append(display)
            announce_page(display, options.qr)
        outputs = Outputs(sinks=tuple(sinks), markers=markers, progress=not options.quiet)
        operator = _Checked(operator, pause, waits=kind in LIVE)  # live: the researcher's prompts
        if kind in LIVE:
            inputs = _LiveInputs(inputs, pause)
        go_on = resume_session if resume else run_session
        try:
            return go_on(store, session_record.id, inputs, clock=clock, operator=operator, rater=rater,
                         outputs=outputs)
        except (KeyboardInterrupt, click.Abort):
            raise click.ClickException(f"session {session_record.id} of {participant_id} paused; the task in "
                                       f"progress will run again from its start on: microg session resume "
                                       f"{store.dir} --participant {participant_id}") from None
        except SourceError as error:
            raise click.ClickException(f"session {session_record.id} of {participant_id} stopped: {error}. "
                                       "Everything logged is kept; the task in progress will run again from its "
                                       f"start on: microg session resume {store.dir} --participant "
                                       f"{participant_id}") from None


class _Pause:
    """Ctrl-C (SIGINT), SIGTERM (a process manager stopping the session) and SIGHUP (its terminal
    closed) pause the session: a KeyboardInterrupt in the session's thread, so the task in progress is
    marked interrupted and the session says how to resume it.

    The handler does not raise wherever the signal lands: Python runs it between any two bytecodes
    of the main thread, callbacks from C code included, where a KeyboardInterrupt turns into another
    error and a traceback (numba unboxing the simulated participant's typed list: "TypeError: can't
    unbox a <class 'numba.typed.typedlist.List'> as a <NULL>"). It notes the signal, and the session
    raises it at its next safe point: each frame (``take``, a ``FrameSink``) and each call of its
    operator, rater and live hand source (``_Checked``). Only while such a call waits for a person,
    the page or a tracker (``waiting``) does the handler raise at once, as Ctrl-C does there: a
    session waiting for an answer, or for frames that no longer come, stops too; and a second signal
    raises at once (someone insists: the session is stuck between safe points)."""

    def __init__(self) -> None:
        self.signal: str | None = None
        self._waiting = False
        self.raised = False
        """Whether the signal has been raised (as KeyboardInterrupt)."""

    def handle(self, number, frame) -> None:
        first = self.signal is None
        if first:
            self.signal = signal.Signals(number).name
        if self._waiting or not first:
            self._raise()

    def check(self) -> None:
        """A safe point: KeyboardInterrupt once a signal came."""
        if self.signal is not None:
            self._raise()

    def _raise(self) -> None:
        self.raised = True
        raise KeyboardInterrupt(self.signal)

    def take(self, moment) -> None:
        self.check()

    @contextlib.contextmanager
    def waiting(self):
        """A wait a signal interrupts where it is (checked once the handler would raise: none is missed)."""
        before, self._waiting = self._waiting, True
        try:
            self.check()
            yield
        finally:
            self._waiting = before


class _Checked:
    """``inner`` (an operator, a rater, a live hand source) with ``pause``'s safe point at each of its
    calls but ``close`` (how a stopping session cleans up); ``waits``: its calls wait for a person, the
    page or a tracker, and a signal stops them there."""

    def __init__(self, inner, pause: _Pause, waits: bool):
        self._inner, self._pause, self._waits = inner, pause, waits

    def __getattr__(self, name: str):
        value = getattr(self._inner, name)
        if not callable(value) or name == "close":
            return value

        def call(*args, **kwargs):
            if not self._waits:
                self._pause.check()
                return value(*args, **kwargs)
            with self._pause.waiting():
                return value(*args, **kwargs)
        return call


class _LiveInputs:
    """Live ``inputs`` whose hand sources wait for frames as ``_Checked`` waits."""

    def __init__(self, inputs, pause: _Pause):
        self.inputs, self.pause = inputs, pause
        self.spec, self.simulated, self.clock = inputs.spec, inputs.simulated, inputs.clock

    def open(self, plan, seed: int):
        return _Checked(self.inputs.open(plan, seed), self.pause, waits=True)

    def close(self) -> None:
        self.inputs.close()


@contextlib.contextmanager
def _pause_on_signals():
    """While a session runs, Ctrl-C (SIGINT), SIGTERM and SIGHUP pause it (``_Pause``); yields the pause.
    A signal after the session's last safe point stops the process as it leaves (``run --all`` does not
    go on to the next participant)."""
    pause = _Pause()
    with handling_stop_signals(pause.handle):
        yield pause
    if pause.signal is not None and not pause.raised:  # it came after the last safe point
        pause.check()


def _runnable(store: Store, participant_id: str, *, simulated: bool, ignore_schedule: bool) -> bool:
    """Whether ``run --all`` runs the participant: a session of theirs is running, or their next is
    due (one handed to a station is left for the station, said later)."""
    latest = store.session_of(participant_id)
    if latest is not None and latest.status == "running":
        return True
    if store.station_holding(participant_id) is not None:
        return True
    try:
        store.schedule_session(participant_id, simulated=simulated, ignore_schedule=ignore_schedule)
    except StoreError:
        return False
    return True


def _outcome(store: Store, participant_id: str, status: str) -> str:
    """How a session ended, with how its tasks stand: ``session of P01: incomplete, 6 tasks: 6 aborted``
    (a training program's names the session: ``session 'train1' of P01: ...``)."""
    session = store.session_of(participant_id)
    named = "" if not store.protocol.program else f" {session.name!r}"
    return f"session{named} of {participant_id}: {status}, {describe_counts(store.task_counts(session.id))}"


@contextlib.contextmanager
def _display(store: Store, options: SessionOptions, kind: str):
    from microg.study.protocol import Viewpoint
    from microg.view.display import ParticipantDisplay
    from microg.view.pageserver import PageError
    from microg.view.tls import FOLDER

    default = store.protocol.viewpoint
    viewpoint = Viewpoint(_point(options.eye, "--eye") or default.eye,
                          _point(options.look_at, "--look-at") or default.look_at,
                          options.fov if options.fov is not None else default.fov_deg)
    hands = None
    if kind == "webxr":
        from microg.hands.webxr import WebXRSource
        hands = WebXRSource(store.protocol.tracking_rate)
    certificate = page_certificate(store.dir / FOLDER, options.host, options.cert, options.key)
    display = ParticipantDisplay(store.protocol, host=options.host, port=options.port, viewpoint=viewpoint,
                                 hands=hands, certificate=certificate)
    try:
        display.start()
    except PageError as error:
        raise click.ClickException(str(error)) from None
    try:
        yield display
    finally:
        display.close()


INPUT_HELP = ("leap (live tracking), webxr (a headset's hand tracking, through the participant's page), "
              "lsl:NAME (another tracker's hands, from the Lab Streaming Layer stream NAME; needs microg[lsl]), "
              "replay:FILE (a recording, replayed for each task; a replay manifest, replay:MANIFEST.toml, gives "
              "each task its own) or simulated[:PROFILE] (a simulated participant; PROFILE practice (skill grows "
              "with each task done), veteran or beginner; default: the group's simulated_profile).")
QUESTIONNAIRE_HELP = ("ask (on the participant's page with --display, else in the terminal), model (the rating "
                      "model, answers marked simulated) or skip; default: ask for leap and webxr, model for "
                      "simulated, skip for replay.")


def session_options(command):
    """The options ``session run`` and ``session resume`` share."""
    options = [
        click.option("--questionnaire", type=click.Choice(["ask", "model", "skip"]), default=None,
                     help=QUESTIONNAIRE_HELP),
        click.option("--display/--no-display", "display", default=None,
                     help="Serve the participant's view (page and WebSocket) from this session; default: on for "
                          "live input (leap, webxr), off for replay and simulated."),
        click.option("--host", default="127.0.0.1", show_default=True,
                     help="Address the participant's view listens on; anything but 127.0.0.1 (e.g. the LAN "
                          "address for a headset on Wi-Fi) serves it over HTTPS and requires a one-time token, "
                          "printed with the address. A headset on USB reaches 127.0.0.1 through "
                          "`adb reverse tcp:PORT tcp:PORT`."),
        click.option("--port", type=click.IntRange(0, 65535), default=0, show_default=True,
                     help="Port of the participant's view (0: a free one; fix it for adb reverse)."),
        *PAGE_OPTIONS,
        click.option("--eye", default=None, help="Screen mode: the participant's eyes X,Y,Z (m, tracker frame); "
                                                 "default: the protocol's display.eye, else framing the places."),
        click.option("--look-at", "look_at", default=None, help="Screen mode: the point X,Y,Z the view centres on."),
        click.option("--fov", type=click.FloatRange(*FOV_RANGE), default=None,
                     help="Screen mode: vertical field of view (degrees) the screen spans from the eyes; "
                          "default: the protocol's display.fov_deg, else 40."),
        click.option("--pace", type=click.FloatRange(min=0, min_open=True), default=1.0, show_default=True,
                     help="With --display, replayed and simulated hands run at this many times real time."),
        click.option("--align", default=None,
                     help="Place replayed recordings in the workspace: start (the first palm at the task's hand "
                          "start), grasp (the tightest thumb-index pinch on the object's start) or X,Y,Z[,RX,RY,RZ] "
                          "(metres, then degrees); logged with each run. A manifest may set it per task."),
        click.option("--lsl", is_flag=True, help="Stream the session on LSL (needs microg[lsl]): task and stage "
                                                 "events as markers, and the tracked and rendered hands and the "
                                                 "object's pose as a MoCap stream at the tracking rate."),
        click.option("--quiet", is_flag=True, help="No progress bars."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


@session.command("run")
@study_dir_argument
@click.option("--participant", "participant_id", help="The participant whose session to run: their next one.")
@click.option("--all", "run_all", is_flag=True,
              help="Run every active participant's next session that is due (resuming unfinished ones).")
@click.option("--session", "session_name", default=None,
              help="A training program's session to run (its name in the protocol's [[sessions]]); default: the "
                   "participant's next. It must be their next: sessions run in order, each once.")
@click.option("--ignore-schedule", is_flag=True,
              help="Run the session even before it is due (after_days after the previous one); the session "
                   "records that it did.")
@click.option("--input", "input_spec", required=True, help=INPUT_HELP)
@session_options
@clear_errors
def run(study_dir: str, participant_id: str | None, run_all: bool, session_name: str | None, ignore_schedule: bool,
        input_spec: str, **shared) -> None:
    """Run a participant's next session: timeline, tasks, questionnaire; everything is logged as it
    happens. A training program's session runs no earlier than its due date (see: microg study schedule)."""
    if bool(participant_id) == run_all:
        raise click.UsageError("give either --participant ID or --all")
    if run_all and session_name:
        raise click.UsageError("--session names one participant's session: give it with --participant")
    kind = parse_input(input_spec)[0]
    options = SessionOptions(**shared)
    with open_study(study_dir) as store:
        if participant_id:
            status = _run_one(store, participant_id, input_spec=input_spec, options=options, resume=False,
                              session=session_name, ignore_schedule=ignore_schedule)
            click.echo(_outcome(store, participant_id, status))
            return
        todo = [p.id for p in store.participants() if p.status == "active"
                and _runnable(store, p.id, simulated=kind == "simulated", ignore_schedule=ignore_schedule)]
        held = {pid: store.station_holding(pid) for pid in todo}
        for pid, station in held.items():
            if station is not None:
                click.echo(f"left out {pid}: handed to station {station[0]} (microg study station); their session "
                           "comes back with microg study merge", err=True)
        todo = [pid for pid in todo if held[pid] is None]
        for pid in tqdm(todo, unit="participant", desc="participants", disable=options.quiet):
            latest = store.session_of(pid)
            resume = latest is not None and latest.status == "running"
            status = _run_one(store, pid, input_spec=None if resume else input_spec, options=options, resume=resume,
                              ignore_schedule=ignore_schedule)
            click.echo(_outcome(store, pid, status))
        click.echo(f"ran {len(todo)} session(s)")


@session.command("resume")
@study_dir_argument
@click.option("--participant", "participant_id", required=True, help="The participant whose session to resume.")
@click.option("--input", "input_spec", default=None, help=INPUT_HELP + " Default: the session's own input.")
@session_options
@clear_errors
def resume(study_dir: str, participant_id: str, input_spec: str | None, **shared) -> None:
    """Carry on a session that was cut off: at its first unfinished task (a task cut off midway runs
    again from its start; its partial frames stay, marked interrupted)."""
    with open_study(study_dir) as store:
        status = _run_one(store, participant_id, input_spec=input_spec, options=SessionOptions(**shared),
                          resume=True)
        click.echo(_outcome(store, participant_id, status))


def _setting(text: str) -> tuple[str, object]:
    name, _, value = text.partition("=")
    if not name or not value:
        raise click.BadParameter(f"{text!r}: give NAME=VALUE, e.g. substeps=8", param_hint="--set")
    try:
        return name, int(value)
    except ValueError:
        try:
            return name, float(value)
        except ValueError:
            return name, value


@session.command("resimulate")
@study_dir_argument
@click.option("--participant", "participants", multiple=True, help="Whose session to re-simulate (repeat).")
@click.option("--all", "every", is_flag=True, help="Every participant with a session.")
@click.option("--interaction", type=click.Choice(sorted(INTERACTION_MODELS)), default=None,
              help="Run every task under this interaction model instead of the protocol's.")
@click.option("--set", "settings", multiple=True, metavar="NAME=VALUE",
              help="A scene setting to change (repeat): tracking_rate, substeps, penetration_stiffness, ...")
@click.option("--label", default=None, help="Name of the re-simulation (its folder); default from the changes.")
@click.option("--quiet", is_flag=True, help="No progress bars.")
@clear_errors
def resimulate_command(*, study_dir: str, participants: tuple[str, ...], every: bool, interaction: str | None,
                       settings: tuple[str, ...], label: str | None, quiet: bool) -> None:
    """Replay the hand motion a session logged through the physics again, under another interaction
    model or scene settings, into STUDY_DIR/resimulated/LABEL (a study of its own, never mixed with
    the original); compare with: microg report STUDY_DIR --compare STUDY_DIR/resimulated/LABEL.

    It shows what the model alone changes for the same motion; it cannot show what the person would
    have done with the other model (people adapt to what they feel)."""
    from microg.study.resimulate import resimulate

    if bool(participants) == every:
        raise click.UsageError("give --participant ID (repeatable) or --all")
    if every:
        with open_study(study_dir, readonly=True) as store:
            participants = tuple(p.id for p in store.participants() if store.session_of(p.id) is not None)
    target = resimulate(study_dir, list(participants), interaction=interaction,
                        settings=dict(_setting(s) for s in settings), label=label, progress=not quiet)
    click.echo(f"re-simulated {len(participants)} session(s) into {target}")


COMMANDS = [session]
