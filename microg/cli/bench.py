"""``microg bench``: the benchmarks of ``microg.bench`` (accuracy, peers, throughput, coldstart)."""

from __future__ import annotations

import importlib
from pathlib import Path

import click


def load(name: str):
    """Import ``microg.bench.<name>``, or say which optional engine it needs."""
    try:
        return importlib.import_module(f"microg.bench.{name}")
    except ModuleNotFoundError as error:
        if error.name in ("mujoco", "pybullet"):
            raise click.ClickException(f"`microg bench {name}` needs {error.name}: pip install 'microg[bench]'") from None
        raise


def _options(function):
    function = click.option("--quick", is_flag=True, help="A fast smoke run: fewer points, shorter scenes.")(function)
    function = click.option("--figures", type=click.Path(file_okay=False, path_type=Path),
                            default=Path("bench-results"), show_default=True,
                            help="Directory for the charts (bench-*.png).")(function)
    function = click.option("--out", type=click.Path(file_okay=False, path_type=Path),
                            default=Path("bench-results"), show_default=True,
                            help="Directory for the CSV files.")(function)
    return function


@click.group()
def bench() -> None:
    """Benchmarks: what accuracy costs, the peers beside us, throughput, cold start. Not part of the tests."""


@bench.command()
@_options
def accuracy(out: Path, figures: Path, quick: bool) -> None:
    """Error against cost over dt, angular integrators and filter windows (accuracy.csv, bench-accuracy.png)."""
    table = load("accuracy").run(out, figures, quick)
    click.echo(f"{len(table)} measurements -> {out / 'accuracy.csv'}, {figures / 'bench-accuracy.png'}")


@bench.command()
@_options
def peers(out: Path, figures: Path, quick: bool) -> None:
    """The same scenes in MuJoCo and PyBullet in one run: errors and per-step time as ratios (peers.csv)."""
    module = load("peers")
    table, ratios = module.run(out, figures, quick)
    click.echo(ratios.to_string(index=False))
    click.echo(f"-> {out / 'peers.csv'}, {out / 'peer_ratios.csv'}, {figures / 'bench-peers.png'}")


@bench.command()
@_options
@click.option("--participants", type=int, default=None, help="Batch size for the simulated-participant batch.")
def throughput(out: Path, figures: Path, quick: bool, participants: int | None) -> None:
    """Steps per second of the live scene, batches of simulated participants, memory per participant."""
    table = load("throughput").run(out, figures, quick, participants)
    click.echo(table.to_string(index=False))
    click.echo(f"-> {out / 'throughput.csv'}, {figures / 'bench-throughput.png'}")


@bench.command()
@_options
def coldstart(out: Path, figures: Path, quick: bool) -> None:
    """Fresh process to first physics frame with an empty compile cache and with a warm one, and a demo's
    first run on two workers: what it compiled, and whether any kernel was compiled twice (coldstart.csv)."""
    table = load("coldstart").run(out, figures, quick)
    click.echo(table.to_string(index=False))
    click.echo(f"-> {out / 'coldstart.csv'}")


@bench.command("power")
@click.option("--quick", is_flag=True, help="A fast smoke run: 100 data sets per n instead of 1000.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-results"),
              show_default=True, help="Directory for power.csv.")
@click.option("--workers", type=click.IntRange(min=1), default=2, show_default=True,
              help="Worker processes of the local Dask cluster.")
def power_bench(out: Path, quick: bool, workers: int) -> None:
    """Monte Carlo power of the paper's 2 x 3 design (1000 data sets x n = 8, 10, 15, 20) on a local Dask
    cluster, against the report's one-by-one analysis (power.csv)."""
    from microg.power.bench import run

    table = run(out, quick, workers)
    click.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    click.echo(f"-> {out / 'power.csv'}")


@bench.command("insilico")
@click.option("--quick", is_flag=True, help="A fast smoke run: 4 participants instead of 30.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-results"),
              show_default=True, help="Folder for insilico.csv.")
@click.option("--workers", type=click.IntRange(min=1), default=2, show_default=True,
              help="Processes for both studies (the in-silico study's shares of its tasks; the demo's sessions).")
def insilico_bench(out: Path, quick: bool, workers: int) -> None:
    """A whole simulated study of the paper's protocol in silico (batched, nothing logged) beside the
    same study logged frame by frame (microg demo), in one run: insilico.csv."""
    from microg.insilico.bench import run

    table = run(out, quick=quick, workers=workers)
    click.echo(table.to_string(index=False))
    click.echo(f"wrote {out / 'insilico.csv'}")


@bench.command("store")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-results"),
              show_default=True, help="Directory for store.csv.")
@click.option("--study", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="Also measure the codecs on this study's frames (e.g. microg demo's, read only) and the check "
                   "on open for writing on a copy of it.")
@click.option("--quick", is_flag=True, help="A fast smoke run: 40 frame batches, fewer repeats.")
def store_bench(out: Path, study: Path | None, quick: bool) -> None:
    """What a frame costs the study log: each codec's bytes, encode and decode time per frame, in the
    same run, and a run read back as view and export read it; where the bytes go, field by field; the
    study's size. And what the log's integrity costs: per frame logged (the batch's checksum and its
    ledger entry) against the whole commit, per frame read, per open (the ledger check), per MB
    checked by study check, and the check on open that every verb that writes runs first: with nothing
    new, with one session new, with no record (store.csv)."""
    from microg.study.bench import run

    run(out, quick, say=click.echo, study=study)
    click.echo(f"-> {out / 'store.csv'}")


@bench.command("display")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-results"),
              show_default=True, help="Directory for display_latency.csv, webxr_latency.csv and "
                                      "display_summary.csv (a row per run is added).")
@click.option("--quick", is_flag=True, help="30 s of each screen session and 15 s of the headset's, instead of "
                                            "the whole simulated session and 60 s.")
@click.option("--size", default="1280x800", show_default=True,
              help="The browser's viewport, WIDTHxHEIGHT (a laptop's screen): without a GPU (SwiftShader) "
                   "drawing time grows with it.")
@click.option("--load", "loads", type=click.IntRange(min=0), multiple=True, default=(0, 2), show_default=True,
              help="CPU-bound processes to run beside every run (started and stopped by the benchmark); "
                   "repeat it to measure at several loads, each in turn (the targets: p95 <= 20 ms at 0, "
                   "<= 40 ms at 2).")
@click.option("--added-latency", "added_latency", type=click.FloatRange(min=0, max=1000), default=0.0,
              metavar="MS", help="Also run the screen with the protocol's phases adding MS of display latency "
                                 "(added_latency_ms) and report the latency's added part at p50 against the "
                                 "setting and one display refresh.")
def display_bench(out: Path, quick: bool, size: str, loads: tuple[int, ...], added_latency: float) -> None:
    """The participant view's latency in headless Chromium at each load: a 110 Hz simulated session's
    physics result to the drawn frame, once with the page adapting what it draws and once held at
    full resolution (display_latency.csv; with --added-latency a third run whose phases add it),
    beside the floor (a minimal WebSocket and WebGL page drawing the same stream, measured the same
    way in the same run), and under WebXR emulation a hand pose read in the page to that pose drawn
    with its physics applied (webxr_latency.csv). Needs chromium, chromium-driver, selenium."""
    from microg.bench.display import run

    try:
        width, height = (int(v) for v in size.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{size!r}: give WIDTHxHEIGHT in pixels, e.g. 1280x800", param_hint="--size") from None
    try:
        run(out, quick, (width, height), tuple(dict.fromkeys(loads)), say=click.echo,
            added_latency_ms=added_latency)
    except (RuntimeError, FileNotFoundError) as error:
        raise click.ClickException(str(error)) from None


COMMANDS = [bench]
