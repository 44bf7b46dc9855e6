"""``microg hands``: import, inspect, record hand recordings and measure the window filter on them."""

from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np

from microg.skeleton import BONES, DIGITS, SIDES
from microg.hands import RecordingError, load_recording, write_recording
from microg.hands.recording import SUFFIX, UNKNOWN, RecordingInfo, record

from .common import ExistingPath, announce_page, page_certificate, page_options, renamed


def _default_output(path: Path) -> Path:
    name = path.name
    for ending in (".gz", ".json", ".lz"):
        name = name.removesuffix(ending)
    return Path.cwd() / f"{name}{SUFFIX}"


def _load(path: Path):
    try:
        return load_recording(path)
    except RecordingError as error:
        raise click.ClickException(str(error)) from None


def _windows(text: str) -> list[int]:
    try:
        if "-" in text:
            low, high = (int(v) for v in text.split("-"))
            windows = list(range(low, high + 1))
        else:
            windows = [int(v) for v in text.split(",")]
    except ValueError:
        windows = []
    if not windows or min(windows) < 1:
        raise click.BadParameter(f"{text!r}: give a range like 1-7 or a list like 1,3,5 of window sizes >= 1")
    return windows


@click.group()
def hands() -> None:
    """Hand recordings: import LeapJS JSON, inspect, record a Leap Motion, report the window filter."""


@hands.command("import")
@click.argument("file", type=ExistingPath(dir_okay=False, path_type=Path))
@click.option("--out", "output", type=click.Path(dir_okay=False, path_type=Path),
              help=f"Recording to write (default: ./NAME{SUFFIX}).")
@click.option("--overwrite", is_flag=True, help="Replace the output if it exists.")
@renamed("-o", "--out")
@renamed("--output", "--out")
@renamed("--force", "--overwrite", flag=True)
def import_command(file: Path, output: Path | None, overwrite: bool) -> None:
    """Convert a LeapJS v2 recording (JSON, plain or .gz) to the project's recording format."""
    recording = _load(file)
    output = output or _default_output(file)
    try:
        written = write_recording(output, recording.info, recording.frames, overwrite=overwrite)
    except FileExistsError as error:
        raise click.ClickException(f"{error} (use --overwrite to replace it)") from None
    click.echo(f"{file} -> {output}: {written} frames, {recording.info.source}")


@hands.command()
@click.argument("recording", type=ExistingPath(dir_okay=False, path_type=Path))
def info(recording: Path) -> None:
    """Show a recording's metadata, timing, hands and bone lengths (either format)."""
    rec = _load(recording)
    frames = rec.frames
    click.echo(f"file          {rec.path}")
    for name in ("source", "device", "frame_rate", "start_time", "units", "coordinates", "notes", "software"):
        value = getattr(rec.info, name)
        if name == "frame_rate":
            value = f"{value:.1f} Hz (as the device reported it)"
        if value != "":
            click.echo(f"{name:<13} {value}")
    status = f"TRUNCATED: {rec.problem}; all {len(frames)} complete frames kept" if rec.truncated else "complete"
    click.echo(f"{'file status':<13} {status}")
    click.echo(f"{'frames':<13} {len(frames)}")
    if len(frames) < 2:
        return
    times = np.array([f.timestamp for f in frames])
    intervals = np.diff(times)
    typical = float(np.median(intervals[intervals > 0])) if (intervals > 0).any() else float("nan")
    gaps = intervals > 1.5 * typical
    click.echo(f"{'duration':<13} {times[-1] - times[0]:.3f} s")
    click.echo(f"{'intervals':<13} median {1e3 * typical:.2f} ms ({1 / typical:.1f} Hz), "
               f"min {1e3 * intervals.min():.2f} ms, max {1e3 * intervals.max():.2f} ms")
    click.echo(f"{'gaps':<13} {int(gaps.sum())} intervals over 1.5x the median "
               f"(about {int(np.maximum(np.round(intervals[gaps] / typical) - 1, 1).sum())} frames missing)")
    click.echo(f"{'order':<13} " + ("timestamps strictly increase" if (intervals > 0).all() else
                                    f"{int((intervals <= 0).sum())} timestamps do not increase "
                                    "(the tracking guard drops those frames)"))
    for side in SIDES:
        seen = [f.hand(side) for f in frames if f.hand(side) is not None]
        if not seen:
            click.echo(f"{side:<13} not tracked")
            continue
        tracks = len({h.track_id for h in seen})
        click.echo(f"{side:<13} tracked in {len(seen)} frames, {tracks} track(s)")
        lengths = np.array([h.bone_lengths for h in seen]) * 1e3
        with np.errstate(invalid="ignore"):
            known = np.isfinite(lengths).all(axis=0)
        click.echo("  bone lengths, mm (median +- SD over frames)")
        click.echo(f"  {'':<8}" + "".join(f"{b:>16}" for b in BONES))
        for d, digit in enumerate(DIGITS):
            cells = [f"{np.median(lengths[:, d, b]):.1f} +- {np.std(lengths[:, d, b]):.2f}" if known[d, b]
                     else "unknown" for b in range(len(BONES))]
            click.echo(f"  {digit:<8}" + "".join(f"{c:>16}" for c in cells))


@hands.command("filter-report")
@click.argument("recording", type=ExistingPath(dir_okay=False, path_type=Path))
@click.option("--windows", default="1-7", show_default=True, help="Window sizes F: a range (1-7) or a list (1,3,5).")
@click.option("--side", type=click.Choice(SIDES), help="Hand to measure (default: the one tracked most).")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), help="Save the trade-off plot here (PNG).")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False, path_type=Path), help="Save the table as CSV.")
def filter_report_command(*, recording: Path, windows: str, side: str | None, plot: Path | None,
                          csv_path: Path | None) -> None:
    """Measure the window filter's jitter and lag for each window size F on a recording.

    The filter is Eq. 1 of the paper, applied to the frames that arrived. Jitter: RMS second
    difference of the fingertips (mm), over gap-free stretches. Lag: the time shift that best
    aligns filtered with raw fingertips (ms; also in frames); sample age: the lag from the
    timestamps alone for a constant velocity. See docs/hand-input.md.
    """
    from microg.hands.filter_report import filter_report, plot_filter_report

    rec = _load(recording)
    try:
        table = filter_report(rec.frames, _windows(windows), side)
    except ValueError as error:
        raise click.ClickException(f"{recording}: {error}") from None
    attrs = table.attrs
    click.echo(f"{rec.path.name}: {attrs['side']} hand, {attrs['frames']} frames in {attrs['tracks']} track(s), "
               f"median period {attrs['period_ms']:.2f} ms")
    click.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if csv_path:
        table.to_csv(csv_path, index=False)
        click.echo(f"table -> {csv_path}")
    if plot:
        plot_filter_report(table, rec.frames, plot, title=f"window filter on {rec.path.name}")
        click.echo(f"plot -> {plot}")


@hands.command("record")
@click.option("--out", "output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help=f"Recording to write (NAME{SUFFIX}).")
@click.option("--input", "input_kind", type=click.Choice(["leap", "webxr"]), default="leap", show_default=True,
              help="leap (a Leap Motion on this machine) or webxr (a headset's own hand tracking, read by the "
                   "participant's page, which this command serves: open it in the headset's browser).")
@click.option("--duration", type=click.FloatRange(min=0, min_open=True),
              help="Seconds to record (default: until Ctrl-C).")
@click.option("--frames", "max_frames", type=click.IntRange(min=1), help="Frames to record at most.")
@click.option("--overwrite", is_flag=True, help="Replace the output if it exists.")
@renamed("--force", "--overwrite", flag=True)
@click.option("--protocol", "protocol_name", default="paper", show_default=True,
              help="With --input webxr: the protocol whose workspace the headset places (a file, or the name "
                   "of a shipped protocol); the joints are recorded in its tracker frame.")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="With --input webxr: the address the page listens on (anything but 127.0.0.1 is served over "
                   "HTTPS and needs the one-time token printed with the address).")
@click.option("--port", type=click.IntRange(0, 65535), default=0, show_default=True,
              help="With --input webxr: the page's port (0: a free one; fix it for adb reverse).")
@page_options
def record_command(*, output: Path, input_kind: str, duration: float | None, max_frames: int | None, overwrite: bool,
                   protocol_name: str, host: str, port: int, cert: str | None, key: str | None,
                   qr: str | None) -> None:
    """Record live hands to a recording file: a Leap Motion (needs Ultraleap's SDK, bindings and a
    device), or a headset's hand tracking through the participant's page (--input webxr)."""
    if output.exists() and not overwrite:
        raise click.ClickException(f"{output}: already exists (use --overwrite to replace it)")
    limits = {"duration": duration, "max_frames": max_frames, "overwrite": overwrite}
    if input_kind == "webxr":
        _record_webxr(output, protocol_name=protocol_name, host=host, port=port, limits=limits, page=(cert, key, qr))
        return
    from microg.hands.leap_device import LeapSource, LeapUnavailable

    try:
        source = LeapSource()
    except LeapUnavailable as error:
        raise click.ClickException(str(error)) from None
    try:
        info = RecordingInfo(source="leap", device=source.device, frame_rate=source.frame_rate, start_time=UNKNOWN)
        click.echo(f"recording {source.device} at {source.frame_rate:.0f} Hz to {output}; Ctrl-C stops")
        summary = record(source, output, info, **limits)
    except LeapUnavailable as error:
        raise click.ClickException(f"{error}; the frames recorded so far are in {output}") from None
    finally:
        source.close()
    dropped = f" ({source.frames_dropped} frames dropped: the writer fell behind)" if source.frames_dropped else ""
    click.echo(f"{summary.frames} frames, {summary.seconds:.2f} s -> {summary.path}{dropped}")


class _Announced:
    """A source whose display hands on what the page measured (clock, placement) before each frame:
    the recording loop is the thread that drives the display here."""

    def __init__(self, source, display):
        self.source, self.display, self.description = source, display, source.description

    def next_frame(self, observation=None):
        self.display.deliver_events()
        return self.source.next_frame(observation)

    def close(self) -> None:
        self.source.close()


def _record_webxr(output: Path, *, protocol_name: str, host: str, port: int, limits: dict,
                  page: tuple[str | None, str | None, str | None]) -> None:
    """``record --input webxr``: serve the participant's page, record the hands it streams; away from
    127.0.0.1 over HTTPS (``page``: --cert, --key, --qr), by default with the certificate microg
    keeps for this user (there is no study folder to keep it in)."""
    from microg.hands.webxr import WebXRSource
    from microg.paths import protocol_file
    from microg.skeleton.cache import user_cache_dir
    from microg.study.protocol import Phase, ProtocolError, load_protocol
    from microg.view.display import ParticipantDisplay
    from microg.view.pageserver import PageError
    from microg.view.tls import FOLDER

    try:
        protocol = load_protocol(protocol_file(protocol_name))
    except (ProtocolError, OSError) as error:
        raise click.ClickException(str(error)) from None
    cert, key, qr = page
    certificate = page_certificate(user_cache_dir() / "microg" / FOLDER, host, cert, key)
    source = WebXRSource(protocol.tracking_rate)

    def say(kind: str, data: dict) -> None:
        """The page's placement and clock, for the researcher's notes."""
        click.echo(f"{kind}: {json.dumps(data)}")

    try:
        with ParticipantDisplay(protocol, host=host, port=port, hands=source, on_event=say,
                                certificate=certificate) as display:
            display.phase(Phase("recording", 0.0, "Your hand movements are being recorded. Move as the researcher "
                                                  "asks you to."))
            announce_page(display, qr)
            click.echo(f"enter mixed reality in the headset's browser and place the workspace; recording to {output} "
                       "starts with the first hand frame; Ctrl-C stops")
            info = RecordingInfo(source="webxr", device=source.device, frame_rate=float("nan"), start_time=UNKNOWN,
                                 notes=f"WebXR Hand Input through the participant's page, in the tracker frame of "
                                       f"protocol {protocol.name} (placed in the headset); timestamps: the page's "
                                       f"read time plus its measured clock offset")
            summary = record(_Announced(source, display), output, info, **limits)
    except PageError as error:
        raise click.ClickException(str(error)) from None
    finally:
        source.close()
    dropped = f" ({source.frames_dropped} frames dropped: the writer fell behind)" if source.frames_dropped else ""
    click.echo(f"{summary.frames} frames, {summary.seconds:.2f} s at {source.frame_rate:.0f} Hz -> {summary.path}"
               f"{dropped}")


COMMANDS = [hands]
